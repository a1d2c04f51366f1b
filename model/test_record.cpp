#include "model/test_record.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <sstream>
#include <string_view>
#include <vector>

#include <memory>

#include "common/cancel.h"
#include "common/lcm_log.h"
#include "common/seq_gaps.h"
#include "common/text.h"
#include "common/wire.h"
#include "model/excitation.h"

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

std::string Where(const std::string& source, int64_t line, bool lcm) {
  return source + (lcm ? ":event " : ":") + std::to_string(line);
}

// Strictly increasing and finite: one series (theta or table). Gaps are
// counted (CountGaps), not errors.
void CheckSeries(const std::string& source, const char* what, const std::vector<double>& t,
                 const std::vector<int64_t>& line, bool lcm) {
  for (std::size_t k = 0; k < t.size(); ++k) {
    if (!std::isfinite(t[k])) Fail(Where(source, line[k], lcm), std::string(what) + " time is not finite");
    if (k > 0 && !(t[k] > t[k - 1])) {
      Fail(Where(source, line[k], lcm),
           std::string(what) + " time does not increase (" + Num(t[k]) + " s after " +
               Num(t[k - 1]) + " s): the record must be in time order without repeats");
    }
  }
}

// Adds `missing` samples lost before the sample at `line`, between times
// t_before and t_after (s), to `g`.
void AddGap(GapCount& g, int64_t missing, double t_before, double t_after, int64_t line) {
  if (missing <= 0) return;
  g.missing_samples = common::SeqGaps::SaturatingAdd(g.missing_samples, missing);
  ++g.gaps;
  if (std::isfinite(t_before) && std::isfinite(t_after)) g.longest_s = std::max(g.longest_s, t_after - t_before);
  if (g.first_line == 0) g.first_line = line;
}

// Samples in an LCM channel: seq jumps and non-finite values are missing.
struct SeqCounter {
  GapCount gaps;
  bool any{false};
  int64_t last_seq{};       // seq of the last event (present or not)
  int64_t pending{};        // missing since the last present sample
  double last_time{std::nan("")};
  // Returns an error text for a sequence that goes back, else empty.
  std::string Event(int64_t seq, bool present, double t, int64_t line) {
    if (any && seq <= last_seq) {
      return "sequence goes back from " + std::to_string(last_seq) + " to " + std::to_string(seq);
    }
    if (any) pending = common::SeqGaps::SaturatingAdd(pending, common::SeqGaps::Skipped(last_seq, seq));
    any = true;
    last_seq = seq;
    if (!present) {
      pending = common::SeqGaps::SaturatingAdd(pending, 1);
      return {};
    }
    AddGap(gaps, pending, last_time, t, line);
    pending = 0;
    last_time = t;
    return {};
  }
  // Missing samples at the end of the log (no present sample after them).
  void Finish() { AddGap(gaps, pending, last_time, last_time, 0); }
};

}  // namespace

GapCount CountGaps(const std::vector<double>& t, const std::vector<int64_t>& line,
                   double max_step_ratio) {
  GapCount g;
  if (t.size() < 3) return g;
  std::vector<double> steps(t.size() - 1);
  for (std::size_t k = 1; k < t.size(); ++k) steps[k - 1] = t[k] - t[k - 1];
  std::vector<double> sorted = steps;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
  const double median = sorted[sorted.size() / 2];
  if (!(median > 0.0)) return g;
  for (std::size_t k = 1; k < t.size(); ++k) {
    const double step = steps[k - 1];
    if (step > max_step_ratio * median) {
      // In double, capped: a wild time (1e20 s after 1 ms steps) must not overflow.
      const double q = std::floor(step / median + 0.5) - 1.0;
      const int64_t missing = q >= 9.2e18 ? std::numeric_limits<int64_t>::max() : std::max<int64_t>(1, static_cast<int64_t>(q));
      AddGap(g, missing, t[k - 1], t[k], k < line.size() ? line[k] : 0);
    }
  }
  return g;
}

RockingRecord ReadRecord(const std::string& path, const RecordOptions& options) {
  RockingRecord r = common::StartsWithLcmSync(path) ? ReadThetaLcmLog(path, options) : ReadThetaCsv(path);
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
  int64_t lost_before_first = 0;  // rows with no theta before the first sample
  int64_t lost_pending = 0;       // since the last sample
  int64_t first_lost_line = 0;
  std::vector<std::string_view> fields;  // views into the trimmed line
  while (std::getline(in, text)) {
    common::PollThreadCancel();
    ++line_no;
    const std::string trimmed(common::Trim(text));
    if (trimmed.empty() || trimmed[0] == '#') continue;
    common::Split(trimmed, ',', fields);
    for (std::string_view& f : fields) f = common::Trim(f);
    if (time_col < 0) {
      for (std::size_t i = 0; i < fields.size(); ++i) {
        if (fields[i] == "time") time_col = static_cast<int>(i);
        if (fields[i] == "theta") theta_col = static_cast<int>(i);
      }
      if (time_col < 0 || theta_col < 0) {
        Fail(Where(path, line_no, false),
             "the header must name the columns time (s) and theta (rad), got " + common::Quote(trimmed));
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
    if (!common::ParseDouble(fields[time_col], t)) {
      Fail(Where(path, line_no, false), "time is not a number: " + common::Quote(fields[time_col]));
    }
    if (!common::ParseDouble(fields[theta_col], theta) || !std::isfinite(theta)) {
      // A lost sample: left out and counted (the time step shows it inside
      // the record; at its ends it is counted here).
      if (r.time_s.empty()) ++lost_before_first;
      ++lost_pending;
      if (first_lost_line == 0) first_lost_line = line_no;
      continue;
    }
    lost_pending = 0;
    r.time_s.push_back(t);
    r.theta.push_back(theta);
    r.line.push_back(line_no);
  }
  if (time_col < 0) throw RecordError(path + ": empty file (no `time,theta` header)");
  CheckSeries(path, "theta", r.time_s, r.line, false);
  r.theta_gaps = CountGaps(r.time_s, r.line);
  const int64_t at_ends = lost_before_first + (r.time_s.empty() ? 0 : lost_pending);
  if (at_ends > 0) {
    r.theta_gaps.missing_samples = common::SeqGaps::SaturatingAdd(r.theta_gaps.missing_samples, at_ends);
    r.theta_gaps.gaps += (lost_before_first > 0 ? 1 : 0) + (lost_pending > 0 && !r.time_s.empty() ? 1 : 0);
    if (r.theta_gaps.first_line == 0 || lost_before_first > 0) r.theta_gaps.first_line = first_lost_line;
  }
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
  SeqCounter block_seq;
  SeqCounter table_seq;
  bool any_block = false;
  while (log->Next(event)) {
    if (!damage.empty()) break;  // reported below, before any gap it causes
    const int datalen = static_cast<int>(ev->data.size());
    if (ev->channel == options.theta_channel) {
      if (common::GuardedDecode(ev->data.data(), datalen, block) != nullptr) {
        Fail(Where(path, ev->number, true),
             options.theta_channel + " event does not decode as rocklab::block_state_t");
      }
      const bool present = std::isfinite(block.theta);
      const double t = static_cast<double>(block.utime) * 1e-6;
      const std::string bad = block_seq.Event(block.seq, present, t, ev->number);
      if (!bad.empty()) Fail(Where(path, ev->number, true), options.theta_channel + " " + bad);
      if (!present) continue;  // a lost sample, counted
      any_block = true;
      r.time_s.push_back(t);
      r.theta.push_back(block.theta);
      r.line.push_back(ev->number);
    } else if (ev->channel == options.table_channel) {
      if (common::GuardedDecode(ev->data.data(), datalen, table) != nullptr) {
        Fail(Where(path, ev->number, true),
             options.table_channel + " event does not decode as rocklab::table_state_t");
      }
      const bool present = std::isfinite(table.acceleration);
      const double t = static_cast<double>(table.utime) * 1e-6;
      const std::string bad = table_seq.Event(table.seq, present, t, ev->number);
      if (!bad.empty()) Fail(Where(path, ev->number, true), options.table_channel + " " + bad);
      if (!present) continue;  // a lost sample, counted
      r.table_time_s.push_back(t);
      r.table_accel_mps2.push_back(table.acceleration);
      table_line.push_back(ev->number);
    }
  }
  if (!damage.empty()) throw RecordError(damage + "; fit a stretch of the test without it");
  block_seq.Finish();
  table_seq.Finish();
  r.theta_gaps = block_seq.gaps;
  r.table_gaps = table_seq.gaps;
  if (!any_block) {
    throw RecordError(path + ": no " + options.theta_channel + " (rocklab::block_state_t) events");
  }
  CheckSeries(path, "table", r.table_time_s, table_line, true);
  return r;
}

void AddTableCsv(const std::string& path, RockingRecord& record) {
  if (record.has_table()) throw RecordError(path + ": " + record.source + " already has a table record");
  AccelerationRows rows;
  try {
    rows = ReadAccelerationRows(path);
  } catch (const std::runtime_error& e) {
    throw RecordError(e.what());
  }
  record.table_time_s = std::move(rows.time_s);
  record.table_accel_mps2 = std::move(rows.accel_mps2);
  if (record.table_time_s.size() < 2) throw RecordError(path + ": fewer than 2 table samples");
  CheckSeries(path, "table", record.table_time_s, rows.line, false);
  record.table_gaps = CountGaps(record.table_time_s, rows.line);
}

void CheckRecord(const RockingRecord& record, const RecordOptions& options) {
  const bool lcm = common::StartsWithLcmSync(record.source);
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
  CheckSeries(record.source, "theta", record.time_s, record.line, lcm);
  if (record.table_time_s.size() != record.table_accel_mps2.size()) {
    throw RecordError(record.source + ": table time and acceleration have different lengths");
  }
}

void WindowRecord(RockingRecord& record, double start_s, double end_s, const RecordOptions& options) {
  if (!(start_s >= 0) || !std::isfinite(start_s)) {
    throw std::invalid_argument("--start must be >= 0 s (from the record's first sample)");
  }
  if (!(end_s >= start_s)) throw std::invalid_argument("--end must not be before --start");
  if (record.time_s.empty()) return;
  const double lo = record.time_s.front() + start_s;
  const double hi = record.time_s.front() + end_s;
  const auto inside = [lo, hi](double t) { return t >= lo && t <= hi; };
  std::size_t kept = 0;
  for (std::size_t k = 0; k < record.size(); ++k) {
    if (!inside(record.time_s[k])) continue;
    record.time_s[kept] = record.time_s[k];
    record.theta[kept] = record.theta[k];
    record.line[kept] = record.line[k];
    ++kept;
  }
  const bool theta_cut = kept != record.size();
  record.time_s.resize(kept);
  record.theta.resize(kept);
  record.line.resize(kept);
  std::size_t table_kept = 0;
  for (std::size_t k = 0; k < record.table_time_s.size(); ++k) {
    if (!inside(record.table_time_s[k])) continue;
    record.table_time_s[table_kept] = record.table_time_s[k];
    record.table_accel_mps2[table_kept] = record.table_accel_mps2[k];
    ++table_kept;
  }
  const bool table_cut = table_kept != record.table_time_s.size();
  record.table_time_s.resize(table_kept);
  record.table_accel_mps2.resize(table_kept);
  // The gaps of the window only (the table's lines are not kept: 0).
  if (theta_cut) record.theta_gaps = CountGaps(record.time_s, record.line, options.max_step_ratio);
  if (table_cut) record.table_gaps = CountGaps(record.table_time_s, {}, options.max_step_ratio);
  CheckRecord(record, options);
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
