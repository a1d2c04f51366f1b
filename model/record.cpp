#include "model/record.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include <memory>

#include "common/lcm_log.h"
#include "common/text.h"
#include "common/wire.h"

#include "rocklab/block_state_t.hpp"
#include "rocklab/table_state_t.hpp"

namespace rocklab::model {
namespace {

std::string Num(double v) {
  std::ostringstream out;
  out.precision(10);
  out << v;
  return out.str();
}

[[noreturn]] void Fail(const std::string& where, const std::string& what) {
  throw RecordError(where + ": " + what);
}

std::string Trim(const std::string& s) { return std::string(common::Trim(s)); }

std::vector<std::string> SplitCsv(const std::string& line) {
  std::vector<std::string> out;
  std::string field;
  std::istringstream in(line);
  while (std::getline(in, field, ',')) out.push_back(Trim(field));
  if (!line.empty() && line.back() == ',') out.emplace_back();
  return out;
}

// Parses the whole field as a number ("nan" parses, as NaN); false otherwise.
bool ParseDouble(const std::string& s, double& v) { return common::ParseDouble(s, v); }

bool StartsWithLcmSyncWord(const std::string& path) { return common::StartsWithLcmSync(path); }

std::string Where(const std::string& source, int64_t line, bool lcm) {
  return source + (lcm ? ":event " : ":") + std::to_string(line);
}

// Strictly increasing, finite, no gap: one series (theta or table).
void CheckSeries(const std::string& source, const char* what, const std::vector<double>& t,
                 const std::vector<int64_t>& line, bool lcm, double max_step_ratio) {
  for (std::size_t k = 0; k < t.size(); ++k) {
    if (!std::isfinite(t[k])) Fail(Where(source, line[k], lcm), std::string(what) + " time is not finite");
    if (k > 0 && !(t[k] > t[k - 1])) {
      Fail(Where(source, line[k], lcm),
           std::string(what) + " time does not increase (" + Num(t[k]) + " s after " +
               Num(t[k - 1]) + " s): the record must be in time order without repeats");
    }
  }
  if (t.size() < 3) return;
  std::vector<double> steps(t.size() - 1);
  for (std::size_t k = 1; k < t.size(); ++k) steps[k - 1] = t[k] - t[k - 1];
  std::vector<double> sorted = steps;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double median = sorted[sorted.size() / 2];
  for (std::size_t k = 1; k < t.size(); ++k) {
    if (steps[k - 1] > max_step_ratio * median) {
      Fail(Where(source, line[k], lcm),
           std::string(what) + " record has a gap: " + Num(steps[k - 1]) + " s between " +
               Num(t[k - 1]) + " s and " + Num(t[k]) + " s (median step " + Num(median) +
               " s); fit a gap-free stretch of the test");
    }
  }
}

}  // namespace

RockingRecord ReadRecord(const std::string& path, const RecordOptions& options) {
  RockingRecord r = StartsWithLcmSyncWord(path) ? ReadThetaLcmLog(path, options) : ReadThetaCsv(path);
  CheckRecord(r, options);
  return r;
}

RockingRecord ReadThetaCsv(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw RecordError(path + ": cannot open the file");
  RockingRecord r;
  r.source = path;
  std::string text;
  int64_t line_no = 0;
  int time_col = -1;
  int theta_col = -1;
  std::size_t n_fields = 0;
  while (std::getline(in, text)) {
    ++line_no;
    const std::string trimmed = Trim(text);
    if (trimmed.empty() || trimmed[0] == '#') continue;
    const std::vector<std::string> fields = SplitCsv(trimmed);
    if (time_col < 0) {
      for (std::size_t i = 0; i < fields.size(); ++i) {
        if (fields[i] == "time") time_col = static_cast<int>(i);
        if (fields[i] == "theta") theta_col = static_cast<int>(i);
      }
      if (time_col < 0 || theta_col < 0) {
        Fail(Where(path, line_no, false),
             "the header must name the columns time (s) and theta (rad), got '" + trimmed + "'");
      }
      n_fields = fields.size();
      continue;
    }
    if (fields.size() != n_fields) {
      Fail(Where(path, line_no, false), "expected " + std::to_string(n_fields) +
                                            " fields as in the header, got " +
                                            std::to_string(fields.size()));
    }
    double t = 0.0;
    double theta = 0.0;
    if (!ParseDouble(fields[time_col], t)) {
      Fail(Where(path, line_no, false), "time is not a number: '" + fields[time_col] + "'");
    }
    if (!ParseDouble(fields[theta_col], theta) || !std::isfinite(theta)) {
      Fail(Where(path, line_no, false),
           "theta is not a number: '" + fields[theta_col] +
               "' (a lost sample: fit a stretch of the test without it)");
    }
    r.time_s.push_back(t);
    r.theta.push_back(theta);
    r.line.push_back(line_no);
  }
  if (time_col < 0) throw RecordError(path + ": empty file (no `time,theta` header)");
  return r;
}

RockingRecord ReadThetaLcmLog(const std::string& path, const RecordOptions& options) {
  // A damaged region of the log loses samples: an error here, as a gap is.
  common::LogReaderOptions read;
  std::string damage;  // the first damaged region
  read.on_problem = [&damage](const common::LogProblem& p) {
    if (damage.empty()) damage = ToString(p);
  };
  std::unique_ptr<common::LogReader> log;
  try {
    log = std::make_unique<common::LogReader>(path, read);
  } catch (const std::runtime_error& e) {
    throw RecordError(path + ": cannot open the LCM log (" + e.what() + ")");
  }
  common::LogEvent event;
  const common::LogEvent* ev = &event;
  RockingRecord r;
  r.source = path;
  std::vector<int64_t> table_line;
  rocklab::block_state_t block{};
  rocklab::table_state_t table{};
  int64_t last_block_seq = 0;
  int64_t last_table_seq = 0;
  bool any_block = false;
  bool any_table = false;
  while (log->Next(event)) {
    if (!damage.empty()) break;  // reported below, before any gap it causes
    const int datalen = static_cast<int>(ev->data.size());
    if (ev->channel == options.theta_channel) {
      if (common::GuardedDecode(ev->data.data(), datalen, block) != nullptr) {
        Fail(Where(path, ev->number, true),
             options.theta_channel + " event does not decode as rocklab::block_state_t");
      }
      if (any_block && block.seq != last_block_seq + 1) {
        Fail(Where(path, ev->number, true),
             options.theta_channel + " sequence jumps from " + std::to_string(last_block_seq) +
                 " to " + std::to_string(block.seq) + ": samples are missing (a gap)");
      }
      if (!std::isfinite(block.theta)) {
        Fail(Where(path, ev->number, true),
             "theta is not a number (a lost sample: fit a stretch of the test without it)");
      }
      any_block = true;
      last_block_seq = block.seq;
      r.time_s.push_back(static_cast<double>(block.utime) * 1e-6);
      r.theta.push_back(block.theta);
      r.line.push_back(ev->number);
    } else if (ev->channel == options.table_channel) {
      if (common::GuardedDecode(ev->data.data(), datalen, table) != nullptr) {
        Fail(Where(path, ev->number, true),
             options.table_channel + " event does not decode as rocklab::table_state_t");
      }
      if (any_table && table.seq != last_table_seq + 1) {
        Fail(Where(path, ev->number, true),
             options.table_channel + " sequence jumps from " + std::to_string(last_table_seq) +
                 " to " + std::to_string(table.seq) + ": samples are missing (a gap)");
      }
      if (!std::isfinite(table.acceleration)) {
        Fail(Where(path, ev->number, true), "table acceleration is not a number");
      }
      any_table = true;
      last_table_seq = table.seq;
      r.table_time_s.push_back(static_cast<double>(table.utime) * 1e-6);
      r.table_accel_mps2.push_back(table.acceleration);
      table_line.push_back(ev->number);
    }
  }
  if (!damage.empty()) throw RecordError(damage + "; fit a stretch of the test without it");
  if (!any_block) {
    throw RecordError(path + ": no " + options.theta_channel + " (rocklab::block_state_t) events");
  }
  CheckSeries(path, "table", r.table_time_s, table_line, true, options.max_step_ratio);
  return r;
}

void AddTableCsv(const std::string& path, RockingRecord& record) {
  if (record.has_table()) throw RecordError(path + ": " + record.source + " already has a table record");
  std::ifstream in(path);
  if (!in) throw RecordError(path + ": cannot open the file");
  std::string text;
  int64_t line_no = 0;
  bool header = false;
  std::vector<int64_t> lines;
  while (std::getline(in, text)) {
    ++line_no;
    const std::string trimmed = Trim(text);
    if (trimmed.empty() || trimmed[0] == '#') continue;
    const std::vector<std::string> fields = SplitCsv(trimmed);
    if (!header) {
      if (fields.size() != 2 || fields[0] != "time" || fields[1] != "accel") {
        Fail(Where(path, line_no, false), "the header must be time,accel (s, m/s^2), got '" + trimmed + "'");
      }
      header = true;
      continue;
    }
    double t = 0.0;
    double a = 0.0;
    if (fields.size() != 2 || !ParseDouble(fields[0], t) || !ParseDouble(fields[1], a) ||
        !std::isfinite(a)) {
      Fail(Where(path, line_no, false), "expected two numbers time,accel, got '" + trimmed + "'");
    }
    record.table_time_s.push_back(t);
    record.table_accel_mps2.push_back(a);
    lines.push_back(line_no);
  }
  if (record.table_time_s.size() < 2) throw RecordError(path + ": fewer than 2 table samples");
  CheckSeries(path, "table", record.table_time_s, lines, false, RecordOptions{}.max_step_ratio);
}

void CheckRecord(const RockingRecord& record, const RecordOptions& options) {
  const bool lcm = StartsWithLcmSyncWord(record.source);
  if (record.time_s.size() != record.theta.size() || record.line.size() != record.time_s.size()) {
    throw RecordError(record.source + ": time, theta and line have different lengths");
  }
  if (static_cast<int>(record.size()) < options.min_samples) {
    throw RecordError(record.source + ": only " + std::to_string(record.size()) +
                      " theta samples; at least " + std::to_string(options.min_samples) +
                      " are needed");
  }
  for (std::size_t k = 0; k < record.size(); ++k) {
    if (!std::isfinite(record.theta[k])) Fail(Where(record.source, record.line[k], lcm), "theta is not finite");
  }
  CheckSeries(record.source, "theta", record.time_s, record.line, lcm, options.max_step_ratio);
  if (record.table_time_s.size() != record.table_accel_mps2.size()) {
    throw RecordError(record.source + ": table time and acceleration have different lengths");
  }
}

void WriteThetaCsv(const std::string& path, const RockingRecord& record) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (!f) throw RecordError(path + ": cannot open for writing");
  std::fprintf(f, "time,theta\n");
  for (std::size_t k = 0; k < record.size(); ++k) {
    std::fprintf(f, "%.10g,%.12g\n", record.time_s[k], record.theta[k]);
  }
  if (std::fclose(f) != 0) throw RecordError(path + ": write failed");
}

}  // namespace rocklab::model
