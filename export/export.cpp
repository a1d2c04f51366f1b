#include "export/export.h"

#include <cmath>
#include <regex>
#include <stdexcept>
#include <unordered_map>

#include "common/lcm_log.h"
#include "common/text.h"
#include "common/wire.h"
#include "daq/source.h"
#include "export/csv_writer.h"
#include "export/fields.h"
#include "export/h5_writer.h"
#include "export/mat_writer.h"

namespace rocklab::exporter {
namespace {

bool InWindow(double t_s, const ExportOptions& o) {
  // --start 0 (the default) leaves nothing out, not even a message a few
  // samples out of order before the first one.
  return (o.start_s <= 0 || t_s >= o.start_s) && (o.end_s < 0 || t_s <= o.end_s);
}

// One (channel, type) of a log being exported.
struct ChannelTable {
  std::unique_ptr<MessageDecoder> decoder;
  int table{-1};      // sink handle, -1 until the first decodable message
  std::size_t summary{};  // index in ExportSummary::tables
  Row row;
  bool warned{false};
};

struct ChannelState {
  bool selected{false};
  // Tables of this channel by fingerprint (almost always one).
  std::vector<std::pair<std::int64_t, ChannelTable>> tables;
};

}  // namespace

void ExportOptions::Validate() const {
  try {
    std::regex r(channels);
  } catch (const std::regex_error& e) {
    throw std::invalid_argument("--channels: not a regular expression: " + channels);
  }
  if (!(start_s >= 0) || !std::isfinite(start_s)) throw std::invalid_argument("--start must be >= 0 s");
  if (!std::isfinite(end_s)) throw std::invalid_argument("--end must be finite");
  if (end_s >= 0 && end_s < start_s) throw std::invalid_argument("--end must not be before --start");
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
  const std::regex select(options.channels);
  std::unordered_map<std::string, ChannelState> channels;
  std::vector<Column> columns;
  bool have_origin = false;
  std::int64_t origin_us = 0;

  common::LogEvent ev;
  while (log.Next(ev)) {
    const int size = static_cast<int>(ev.data.size());
    const std::int64_t fingerprint = common::WireFingerprint(ev.data.data(), size);
    const MessageType* type = FindMessageType(fingerprint);
    // The record's first sample: the first message of a rocklab type whose
    // lengths are sound, whatever the channel filter (so windows agree
    // between exports of different channels).
    if (!have_origin && type && !common::WireCheck(*type->layout, ev.data.data(), size)) {
      std::int64_t utime = 0;
      for (int k = 8; k < 16; ++k) utime = (utime << 8) | ev.data[static_cast<std::size_t>(k)];
      origin_us = utime;
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
    if (!InWindow(static_cast<double>(t->decoder->utime() - origin_us) * 1e-6, options)) {
      ++summary.outside_window;
      continue;
    }
    if (t->table < 0) {
      t->decoder->Columns(columns);
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
  for (const std::string& name : source->channel_names()) {
    std::string unit;
    for (const auto& [n, u] : options.units) {
      if (n == name) unit = u;
    }
    columns.push_back({name, ColumnType::kDouble, unit});
  }
  const int table = sink.AddTable("data", columns);
  sink.Describe(table, "source", path);
  Row row;
  row.Resize(columns.size());
  daq::Frame frame;
  daq::ReadStatus status;
  bool have_origin = false;
  double origin_s = 0;
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
    for (std::size_t i = 0; i + 1 < columns.size(); ++i) {
      row.real[i + 1] = i < frame.values.size() ? frame.values[i] : std::nan("");
    }
    sink.Append(table, row);
    ++summary.rows;
  }
  if (status == daq::ReadStatus::kError) summary.read_error = source->error();
  summary.tables.push_back({"data", "raw", summary.rows, 0});
  summary.bad_rows = source->stats().bad_rows;
  summary.bad_values = source->stats().bad_values;
  return summary;
}

}  // namespace rocklab::exporter
