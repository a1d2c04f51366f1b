#include "export/export.h"

#include <cmath>
#include <cstdlib>
#include <regex>
#include <stdexcept>
#include <unordered_map>

#include "common/channel_pattern.h"
#include "common/lcm_log.h"
#include "common/text.h"
#include "common/bus.h"
#include "common/wire.h"
#include "daq/source.h"
#include "export/csv_writer.h"
#include "export/fields.h"
#include "export/h5_writer.h"
#include "export/mat_writer.h"
#include "common/versions.h"
#include "rocklab/daq_config2_t.hpp"
#include "rocklab/daq_config_t.hpp"
#include "rocklab/raw_frame_t.hpp"

namespace rocklab::exporter {
namespace {

bool InWindow(double t_s, const ExportOptions& o) {
  // --start 0 (the default) leaves nothing out, not even a message a few
  // samples out of order before the first one.
  return (o.start_s <= 0 || t_s >= o.start_s) && t_s <= o.end_s;
}

// A raw_frame_t column named after a rig channel: values_k (raw) copied,
// or calibrated.
struct NamedRaw {
  std::size_t from;  // values_k's column
  std::size_t to;    // the named column
  double gain{1.0}, offset{0.0};
};

// One (channel, type) of a log being exported.
struct ChannelTable {
  std::unique_ptr<MessageDecoder> decoder;
  int table{-1};      // sink handle, -1 until the first decodable message
  std::size_t summary{};  // index in ExportSummary::tables
  Row row;
  bool warned{false};
  std::vector<NamedRaw> named;  // raw_frame_t: the channel-named columns
  bool calibrated{false};
};

// The shortest of %.15g..%.17g that reads back to x ("0.05", not
// "0.050000000000000003").
std::string Number(double x) {
  std::string text;
  for (int digits = 15; digits <= 17; ++digits) {
    text = common::Format("%.*g", digits, x);
    if (std::strtod(text.c_str(), nullptr) == x) break;
  }
  return text;
}

// A dataset-safe, unique column name for channel `name` (HDF5 takes '/' for
// a path; an empty name or one a field has already is prefixed).
std::string ColumnName(const std::string& name, const std::vector<Column>& columns) {
  std::string base = name;
  for (char& c : base) {
    if (c == '/') c = '_';
  }
  std::string n = base;
  auto taken = [&columns](const std::string& x) {
    if (x.empty() || x == "." || x == "..") return true;
    for (const Column& c : columns) {
      if (c.name == x) return true;
    }
    return false;
  };
  if (taken(n)) n = "channel_" + base;
  for (int k = 2; taken(n); ++k) n = "channel_" + base + "_" + std::to_string(k);
  return n;
}

// raw_frame_t's columns named after the rig's channels (`config`): one per
// values_k that the config names, appended after the fields; values_k get
// a description saying which channel they are.
void NameRawColumns(const rocklab::daq_config2_t& config, bool calibrated, std::vector<Column>& columns,
                    ChannelTable& t) {
  t.named.clear();
  t.calibrated = calibrated;
  std::size_t first = columns.size();
  for (std::size_t i = 0; i < columns.size(); ++i) {
    if (columns[i].name == "values_0") first = i;
  }
  for (std::size_t k = 0; first + k < columns.size() && k < config.channel_names.size(); ++k) {
    const std::size_t from = first + k;
    if (columns[from].name != "values_" + std::to_string(k)) break;
    const std::string& name = config.channel_names[k];
    const std::string unit = k < config.channel_units.size() ? config.channel_units[k] : "";
    const std::string sensor = k < config.channel_sensors.size() ? config.channel_sensors[k] : "";
    const double gain = k < config.gain.size() ? config.gain[k] : 1.0;
    const double offset = k < config.offset.size() ? config.offset[k] : 0.0;
    const std::string calibration = "physical = gain * raw + offset in " + (unit.empty() ? "?" : unit) +
                                    ", gain " + Number(gain) + ", offset " + Number(offset) +
                                    " (RL_DAQ_CONFIG, rig " + config.rig_name + ", calibration " +
                                    config.calibration_id + ")";
    columns[from].description = "channel " + name + (sensor.empty() ? "" : " (sensor " + sensor + ")") +
                                ", raw; " + calibration;
    Column c;
    c.name = ColumnName(name, columns);
    c.type = ColumnType::kDouble;
    if (calibrated) {
      c.unit = unit;
      c.description = "channel " + name + (sensor.empty() ? "" : " (sensor " + sensor + ")") +
                      ", calibrated from values_" + std::to_string(k) + ": " + calibration;
    } else {
      c.description = "channel " + name + (sensor.empty() ? "" : " (sensor " + sensor + ")") +
                      ", raw (= values_" + std::to_string(k) + "); " + calibration;
      c.same_as = columns[from].name;  // HDF5: one dataset, two names
    }
    columns.push_back(c);
    t.named.push_back({from, columns.size() - 1, gain, offset});
  }
}

struct ChannelState {
  bool selected{false};
  // Tables of this channel by fingerprint (almost always one).
  std::vector<std::pair<std::int64_t, ChannelTable>> tables;
};

}  // namespace

RawRate ChooseRawRate(double rate_hz, const std::string& rate_name, double rig_rate_hz, const std::string& rig_path) {
  if (rate_hz > 0 || rig_path.empty()) return {rate_hz, rate_name};
  return {rig_rate_hz, "the rig's sample_rate_hz (" + rig_path + ")"};
}

void ExportOptions::Validate() const {
  common::ChannelPattern(channels, "--channels");
  if (!(start_s >= 0) || !std::isfinite(start_s)) throw std::invalid_argument("--start must be >= 0 s");
  if (!(end_s >= 0)) {
    throw std::invalid_argument("--end must be >= 0 s (leave it out to read to the end), got " +
                                common::Format("%g", end_s));
  }
  if (end_s < start_s) throw std::invalid_argument("--end must not be before --start");
  if (!(sample_rate_hz >= 0) || !std::isfinite(sample_rate_hz)) throw std::invalid_argument("--rate must be >= 0 Hz");
}

std::unique_ptr<TableSink> OpenSink(const std::string& out, bool single_table) {
  if (common::HasExtension(out, ".csv")) return std::make_unique<CsvWriter>(out, single_table);
  if (common::HasExtension(out, ".mat")) return std::make_unique<MatWriter>(out);
  if (common::HasExtension(out, ".h5") || common::HasExtension(out, ".hdf5")) {
    return std::make_unique<H5Writer>(out);
  }
  throw std::invalid_argument("--out " + out + ": the extension must be .csv, .mat or .h5");
}

bool IsLcmLog(const std::string& path) { return common::StartsWithLcmSync(path); }

ExportSummary ExportLog(const std::string& path, const ExportOptions& options, TableSink& sink,
                        const std::function<void(const std::string&)>& on_problem) {
  options.Validate();
  ExportSummary summary;
  common::LogReaderOptions read;
  read.on_problem = [&](const common::LogProblem& p) {
    if (on_problem) on_problem(common::ToString(p));
  };
  std::unique_ptr<common::LogReader> opened;
  try {
    opened = std::make_unique<common::LogReader>(path, read);
  } catch (const std::exception& e) {
    throw InputError(e.what());
  }
  common::LogReader& log = *opened;
  const std::regex select = common::ChannelPattern(options.channels, "--channels");
  std::unordered_map<std::string, ChannelState> channels;
  std::vector<Column> columns;
  bool have_origin = false;
  std::int64_t origin_us = 0;
  // The first daq_config2_t (or an older log's daq_config_t) on any channel
  // (selected or not): what RL_RAW's columns are named after.
  const std::int64_t config_fingerprint = rocklab::daq_config2_t::getHash();
  const std::int64_t config_v1_fingerprint = rocklab::daq_config_t::getHash();
  common::DaqConfigDecoder decode_config;
  const std::int64_t raw_fingerprint = rocklab::raw_frame_t::getHash();
  rocklab::daq_config2_t config, last, later;  // the first, the last seen, the one read
  bool have_config = false;

  common::LogEvent ev;
  while (log.Next(ev)) {
    const int size = static_cast<int>(ev.data.size());
    const std::int64_t fingerprint = common::WireFingerprint(ev.data.data(), size);
    const MessageType* type = FindMessageType(fingerprint);
    if (fingerprint == config_fingerprint || fingerprint == config_v1_fingerprint) {
      if (!have_config) {
        have_config = decode_config(ev.data.data(), size, config) == nullptr;
        last = config;
      } else if (decode_config(ev.data.data(), size, later) == nullptr) {
        if (on_problem && (later.channel_names != last.channel_names || later.channel_units != last.channel_units ||
                           later.gain != last.gain || later.offset != last.offset)) {
          // A recalibration or another rig mid-log: said, since RL_RAW's
          // named columns keep the first config (info counts these changes).
          on_problem(path + ": event " + std::to_string(ev.number) + " on " + ev.channel +
                     ": RL_DAQ_CONFIG changed its channels or calibration; RL_RAW's channel-named columns keep "
                     "the first config's names" + std::string(options.calibrated ? " and calibration" : "") +
                     " (values_0.. are as sent)");
        }
        std::swap(last, later);
      }
    }
    // The record's first sample: the first message of a rocklab type whose
    // lengths are sound, whatever the channel filter (so windows agree
    // between exports of different channels).
    if (!have_origin && type && !common::WireCheck(*type->layout, ev.data.data(), size)) {
      origin_us = common::PayloadUtime(ev.data.data(), size, 0);  // unsigned shifts: any bytes
      have_origin = true;
    }
    auto [it, inserted] = channels.try_emplace(ev.channel);
    ChannelState& ch = it->second;
    if (inserted) ch.selected = std::regex_match(ev.channel, select);
    if (!ch.selected) {
      ++summary.filtered;
      continue;
    }
    if (!type) {
      ++summary.unknown_type;
      continue;
    }
    ChannelTable* t = nullptr;
    for (auto& [fp, table] : ch.tables) {
      if (fp == fingerprint) t = &table;
    }
    if (!t) {
      ch.tables.emplace_back(fingerprint, ChannelTable{});
      t = &ch.tables.back().second;
      t->decoder = type->make();
    }
    if (const char* why = t->decoder->Decode(ev.data.data(), size)) {
      ++summary.undecodable;
      if (!t->warned && on_problem) {
        on_problem(path + ": event " + std::to_string(ev.number) + " on " + ev.channel + " (" +
                   type->name + ") does not decode: " + why + " (counted; later ones too)");
      }
      t->warned = true;
      continue;
    }
    if (!InWindow((static_cast<double>(t->decoder->utime()) - static_cast<double>(origin_us)) * 1e-6, options)) {
      ++summary.outside_window;
      continue;
    }
    if (t->table < 0) {
      t->decoder->Columns(columns);
      if (fingerprint == raw_fingerprint) {
        if (have_config) {
          NameRawColumns(config, options.calibrated, columns, *t);
        } else if (on_problem) {
          on_problem(path + ": event " + std::to_string(ev.number) + " on " + ev.channel +
                     ": no daq_config_t (RL_DAQ_CONFIG) before the first raw frame: its columns stay "
                     "values_0.. without channel names");
        }
      }
      std::string name = ev.channel;
      if (ch.tables.size() > 1) name += std::string("_") + type->name;
      t->table = sink.AddTable(name, columns);
      sink.Describe(t->table, "channel", ev.channel);
      sink.Describe(t->table, "lcm_type", std::string("rocklab.") + type->name);
      t->row.Resize(columns.size());
      t->summary = summary.tables.size();
      summary.tables.push_back({ev.channel, type->name, 0, 0});
    }
    if (!t->decoder->Fill(t->row)) ++summary.tables[t->summary].reshaped;
    for (const NamedRaw& n : t->named) {
      const double raw = t->row.real[n.from];
      t->row.real[n.to] = t->calibrated ? n.gain * raw + n.offset : raw;
    }
    sink.Append(t->table, t->row);
    ++summary.tables[t->summary].rows;
    ++summary.rows;
  }
  const common::LogReadCounts& c = log.counts();
  summary.damaged_regions = c.damaged_regions;
  summary.damaged_bytes = c.damaged_bytes;
  summary.damaged_events = c.damaged_events;
  return summary;
}

ExportSummary ExportRaw(const std::string& path, const ExportOptions& options, TableSink& sink,
                        const std::function<void(const std::string&)>& on_problem) {
  options.Validate();
  ExportSummary summary;
  daq::SourceOptions so;
  so.sample_rate_hz = options.sample_rate_hz;
  so.rate_origin = options.rate_origin;
  so.on_problem = [&](const daq::Problem& p) {
    if (on_problem) on_problem(daq::ToString(p));
  };
  std::unique_ptr<daq::Source> source;
  try {
    source = daq::OpenSource(path, so);
  } catch (const std::exception& e) {
    throw InputError(e.what());
  }
  std::vector<Column> columns{{"time", ColumnType::kDouble, "s"}};
  const std::vector<std::string>& names = source->channel_names();
  const std::vector<std::string> file_units = source->channel_units();
  for (std::size_t i = 0; i < names.size(); ++i) {
    std::string rig_unit;
    for (const auto& [n, u] : options.units) {
      if (n == names[i]) rig_unit = u;
    }
    Column c{names[i], ColumnType::kDouble, rig_unit};
    if (i < file_units.size() && !file_units[i].empty()) {
      c.unit = file_units[i];
      c.description = "raw values, unit from the file (LVM Y_Unit_Label)";
      if (!rig_unit.empty() && rig_unit != c.unit) c.description += "; the rig calibrates them to " + rig_unit;
    } else if (!rig_unit.empty()) {
      c.description = "raw values; unit: the rig's raw unit for the channel (--rig: raw_unit, or unit when "
                      "gain 1 and offset 0; the file states none)";
    }
    columns.push_back(c);
  }
  // LVM's Comment column: a text column after the channels.
  std::size_t comment = 0;
  if (source->has_comments()) {
    Column c{ColumnName("comment", columns), ColumnType::kString, ""};
    c.description = "the row's Comment text in the LVM file (\"\" for none)";
    columns.push_back(c);
    comment = columns.size() - 1;
  }
  const int table = sink.AddTable("data", columns);
  sink.Describe(table, "source", path);
  Row row;
  row.Resize(columns.size());
  daq::Frame frame;
  daq::ReadStatus status;
  bool have_origin = false;
  double origin_s = 0;
  std::int64_t comments_lost = 0;
  while ((status = source->Next(frame)) == daq::ReadStatus::kFrame) {
    if (!have_origin) {
      origin_s = frame.time_s;
      have_origin = true;
    }
    if (!InWindow(frame.time_s - origin_s, options)) {
      ++summary.outside_window;
      continue;
    }
    row.real[0] = frame.time_s;
    for (std::size_t i = 0; i < names.size(); ++i) {
      row.real[i + 1] = i < frame.values.size() ? frame.values[i] : std::nan("");
    }
    if (comment > 0) {
      row.text[comment] = frame.comment;
      if (!frame.comment.empty()) ++summary.comments;
    } else if (!frame.comment.empty()) {
      ++comments_lost;
    }
    sink.Append(table, row);
    ++summary.rows;
  }
  if (status == daq::ReadStatus::kError) summary.read_error = source->error();
  summary.tables.push_back({"data", "raw", summary.rows, 0});
  summary.bad_rows = source->stats().bad_rows;
  summary.bad_values = source->stats().bad_values;
  summary.empty_values = source->stats().empty_values;
  if (comments_lost > 0 && on_problem) {
    // The table's columns are fixed by the first segment's header.
    on_problem(path + ": " + std::to_string(comments_lost) +
               " comments of a later segment not kept: the file's first segment has no Comment column");
  }
  return summary;
}

}  // namespace rocklab::exporter
