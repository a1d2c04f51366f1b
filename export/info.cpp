#include "export/info.h"

#include <sys/stat.h>

#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>

#include "common/lcm_log.h"
#include "common/seq_gaps.h"
#include "common/text.h"
#include "common/versions.h"
#include "common/wire.h"
#include "daq/source.h"
#include "export/fields.h"

namespace rocklab::exporter {
namespace {

std::int64_t FileBytes(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 ? static_cast<std::int64_t>(st.st_size) : 0;
}

struct ChannelWork {
  ChannelInfo info;
  std::vector<std::pair<std::int64_t, std::unique_ptr<MessageDecoder>>> decoders;
  std::int64_t decoded{};
  common::ChannelSeqGaps seq;  // per sender on RL_EVENT and RL_HEALTH
};

void Rate(ChannelInfo& c, std::int64_t decoded) {
  const double span = c.last_time - c.first_time;
  c.rate_hz = decoded > 1 && span > 0 ? static_cast<double>(decoded - 1) / span : 0.0;
}

using common::Format;

// A name, unit or path from the file in the text report: escaped, and cut
// well inside Format's 511 bytes so that the line's numbers stay.
std::string Field(const std::string& text) { return common::Printable(text, 160); }

nlohmann::json JsonNumber(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); }

}  // namespace

LogInfo ReadLogInfo(const std::string& path) {
  LogInfo info;
  info.path = path;
  info.file_bytes = FileBytes(path);
  common::LogReader log(path);
  std::map<std::string, ChannelWork> channels;
  // daq_config2_t, or daq_config_t from a log written before it.
  const std::int64_t config_hash = rocklab::daq_config2_t::getHash();
  const std::int64_t config_v1_hash = rocklab::daq_config_t::getHash();
  common::DaqConfigDecoder decode_config;
  rocklab::daq_config2_t config, first_config;
  std::int64_t first_stamp = 0, last_stamp = 0;
  common::LogEvent ev;
  while (log.Next(ev)) {
    if (info.events++ == 0) first_stamp = ev.timestamp_us;
    last_stamp = std::max(last_stamp, ev.timestamp_us);
    const int size = static_cast<int>(ev.data.size());
    ChannelWork& ch = channels[ev.channel];
    ChannelInfo& c = ch.info;
    const std::int64_t fingerprint = common::WireFingerprint(ev.data.data(), size);
    if (c.count++ == 0) {
      c.name = ev.channel;
      c.fingerprint = fingerprint;
    }
    c.bytes += size;
    const MessageType* type = FindMessageType(fingerprint);
    if (!type) {
      if (c.type.empty()) c.type = "unknown";
      continue;
    }
    MessageDecoder* decoder = nullptr;
    for (auto& [fp, d] : ch.decoders) {
      if (fp == fingerprint) decoder = d.get();
    }
    if (!decoder) {
      ch.decoders.emplace_back(fingerprint, type->make());
      decoder = ch.decoders.back().second.get();
      c.type = c.type.empty() || c.type == "unknown" ? type->name : c.type + "," + type->name;
    }
    if (decoder->Decode(ev.data.data(), size)) {
      ++c.undecodable;
      continue;
    }
    const double t = static_cast<double>(decoder->utime()) / 1e6;  // as export's time column
    if (ch.decoded++ == 0) {
      c.first_time = c.last_time = t;
      c.has_time = true;
    }
    c.first_time = std::min(c.first_time, t);
    c.last_time = std::max(c.last_time, t);
    if (!info.has_time) {
      info.first_time = info.last_time = t;
      info.has_time = true;
    }
    info.first_time = std::min(info.first_time, t);
    info.last_time = std::max(info.last_time, t);
    // Every current rocklab type's seq (common::WireSeq; older types have none).
    std::int64_t s = 0;
    std::string_view sender;
    if (common::WireSeq(ev.data.data(), size, s, sender)) {
      ch.seq.Add(sender, s);
      c.has_seq = true;
      c.seq_gaps = ch.seq.gaps;
      c.seq_missing = ch.seq.missing;
      c.seq_back = ch.seq.back;
      c.seq_late = ch.seq.late;
      c.seq_duplicates = ch.seq.duplicates;
      c.seq_restarts = ch.seq.restarts;
      c.seq_wild = ch.seq.wild;
    }
    if ((fingerprint == config_hash || fingerprint == config_v1_hash) &&
        !decode_config(ev.data.data(), size, config)) {
      ++info.config_messages;
      if (!info.has_config) {
        info.has_config = true;
        first_config = config;
        info.rig = config.rig_name;
        info.calibration = config.calibration_id;
        info.config_rate_hz = config.sample_rate_hz;
        info.config_channels = config.channel_names;
        info.config_units = config.channel_units;
        info.config_sensors = config.channel_sensors;
        info.alpha = config.alpha;
        info.p = config.p;
        info.mu = config.mu;
      } else {
        // utime and seq differ by design; everything else should not.
        config.utime = first_config.utime;
        config.seq = first_config.seq;
        if (config.getEncodedSize() != first_config.getEncodedSize() ||
            config.rig_name != first_config.rig_name || config.calibration_id != first_config.calibration_id ||
            config.channel_names != first_config.channel_names || config.gain != first_config.gain ||
            config.offset != first_config.offset || config.channel_units != first_config.channel_units ||
            config.sample_rate_hz != first_config.sample_rate_hz || config.alpha != first_config.alpha ||
            config.p != first_config.p || config.mu != first_config.mu) {
          ++info.config_changes;
        }
      }
    }
  }
  for (auto& [name, ch] : channels) {
    Rate(ch.info, ch.decoded);
    info.channels.push_back(ch.info);
  }
  info.duration = info.has_time ? info.last_time - info.first_time : 0.0;
  info.log_duration = static_cast<double>(last_stamp - first_stamp) * 1e-6;
  const common::LogReadCounts& counts = log.counts();
  info.damaged_regions = counts.damaged_regions;
  info.damaged_bytes = counts.damaged_bytes;
  info.damaged_events = counts.damaged_events;
  return info;
}

RawInfo ReadRawInfo(const std::string& path, double sample_rate_hz,
                    const std::vector<std::pair<std::string, std::string>>& units, const std::string& rate_origin) {
  RawInfo info;
  info.path = path;
  info.format = common::HasExtension(path, ".lvm") ? "lvm" : "csv";
  info.file_bytes = FileBytes(path);
  daq::SourceOptions so;
  so.sample_rate_hz = sample_rate_hz;
  so.rate_origin = rate_origin;
  std::unique_ptr<daq::Source> source = daq::OpenSource(path, so);
  info.channels = source->channel_names();
  info.file_units = source->channel_units();
  info.file_units.resize(info.channels.size());
  for (std::size_t i = 0; i < info.channels.size(); ++i) {
    std::string unit;
    for (const auto& [n, u] : units) {
      if (n == info.channels[i]) unit = u;
    }
    info.rig_units.push_back(unit);
    info.units.push_back(info.file_units[i].empty() ? unit : info.file_units[i]);
  }
  info.rate_hz = source->sample_rate_hz();
  daq::Frame frame;
  daq::ReadStatus status;
  common::SeqGaps seq;
  while ((status = source->Next(frame)) == daq::ReadStatus::kFrame) {
    if (info.rows++ == 0) {
      info.first_time = info.last_time = frame.time_s;
      info.has_time = true;
    }
    seq.Add(frame.seq);
    info.first_time = std::min(info.first_time, frame.time_s);
    info.last_time = std::max(info.last_time, frame.time_s);
  }
  info.seq_gaps = seq.gaps();
  info.seq_missing = seq.missing();
  if (status == daq::ReadStatus::kError) info.read_error = source->error();
  const daq::SourceStats& s = source->stats();
  info.bad_rows = s.bad_rows;
  info.bad_values = s.bad_values;
  info.empty_values = s.empty_values;
  info.comments = s.comments;
  info.warnings = s.warnings;
  info.segments = info.format == "lvm" ? s.segments : (info.rows > 0 ? 1 : 0);
  info.span = info.last_time - info.first_time;
  info.measured_rate_hz = info.rows > 1 && info.span > 0 ? static_cast<double>(info.rows - 1) / info.span : 0.0;
  return info;
}

std::string ToText(const LogInfo& info) {
  std::string out;
  out += Format("log:       %s (%" PRId64 " bytes, %" PRId64 " events)\n", Field(info.path).c_str(), info.file_bytes,
             info.events);
  if (info.has_time) {
    out += Format("duration:  %.6f s on the sample clock (%.6f s .. %.6f s); log stamps span %.6f s\n",
               info.duration, info.first_time, info.last_time, info.log_duration);
  } else {
    out += "duration:  no decodable rocklab message\n";
  }
  if (info.has_config) {
    out += Format("rig:       %s, calibration %s, %.9g Hz, alpha %.9g rad, p %.9g rad/s, mu %.9g\n",
               Field(info.rig).c_str(), Field(info.calibration).c_str(), info.config_rate_hz, info.alpha, info.p,
               info.mu);
    std::string list;
    for (std::size_t i = 0; i < info.config_channels.size(); ++i) {
      list += (i ? ", " : "") + Field(info.config_channels[i]);
      if (i < info.config_units.size() && !info.config_units[i].empty()) {
        list += " [" + Field(info.config_units[i]) + "]";
      }
    }
    out += Format("           %zu channels: ", info.config_channels.size()) + list + "\n";
    out += Format("           %" PRId64 " RL_DAQ_CONFIG messages, %" PRId64 " differ from the first\n",
               info.config_messages, info.config_changes);
  } else {
    out += "rig:       no RL_DAQ_CONFIG in the log\n";
  }
  out += Format("damaged:   %" PRId64 " regions, %" PRId64 " bytes, %" PRId64 " events lost\n",
             info.damaged_regions, info.damaged_bytes, info.damaged_events);
  out += Format("%-22s %-16s %9s %14s %14s %11s %16s %11s\n", "channel", "type", "count", "first_time_s",
             "last_time_s", "rate_hz", "seq_gaps", "undecodable");
  for (const ChannelInfo& c : info.channels) {
    const std::string name = Field(c.name);
    std::string type = c.type;
    if (type == "unknown") type = Format("unknown (fingerprint 0x%016" PRIx64 ")", static_cast<std::uint64_t>(c.fingerprint));
    const std::string gaps =
        c.has_seq ? Format("%" PRId64 " (%" PRId64 " missing)", c.seq_gaps, c.seq_missing) : std::string("-");
    if (c.has_time) {
      out += Format("%-22s %-16s %9" PRId64 " %14.6f %14.6f %11.3f %16s %11" PRId64 "\n", name.c_str(),
                 type.c_str(), c.count, c.first_time, c.last_time, c.rate_hz, gaps.c_str(), c.undecodable);
    } else {
      out += Format("%-22s %-16s %9" PRId64 " %14s %14s %11s %16s %11" PRId64 "\n", name.c_str(), type.c_str(),
                 c.count, "-", "-", "-", gaps.c_str(), c.undecodable);
    }
  }
  return out;
}

std::string ToText(const RawInfo& info) {
  std::string out;
  out += Format("file:      %s (%s, %" PRId64 " bytes)\n", Field(info.path).c_str(), info.format.c_str(),
                info.file_bytes);
  out += Format("rows:      %" PRId64 " (%" PRId64 " bad rows skipped, %" PRId64 " bad values and %" PRId64
             " empty values read as NaN, %" PRId64 " warnings)\n",
             info.rows, info.bad_rows, info.bad_values, info.empty_values, info.warnings);
  if (info.comments > 0) out += Format("comments:  %" PRId64 " rows with Comment text\n", info.comments);
  if (info.has_time) {
    out += Format("time:      %.9g s .. %.9g s, span %.9g s\n", info.first_time, info.last_time, info.span);
  }
  out += Format("rate:      %.9g Hz nominal, %.9g Hz measured\n", info.rate_hz, info.measured_rate_hz);
  out += Format("segments:  %" PRId64 "\n", info.segments);
  out += Format("gaps:      %" PRId64 " (%" PRId64 " samples missing)\n", info.seq_gaps, info.seq_missing);
  out += Format("channels:  %zu\n", info.channels.size());
  for (std::size_t i = 0; i < info.channels.size(); ++i) {
    const std::string file = i < info.file_units.size() ? Field(info.file_units[i]) : std::string();
    const std::string rig = i < info.rig_units.size() ? Field(info.rig_units[i]) : std::string();
    std::string unit;
    if (!file.empty()) {
      unit = file + ", from the file";
      if (!rig.empty() && rig != file) unit += "; the rig calibrates to " + rig;
    } else if (!rig.empty()) {
      unit = rig + ", from the rig";
    } else {
      unit = "raw, unit not in the file";
    }
    out += "  " + Field(info.channels[i]) + "  [" + unit + "]\n";
  }
  if (!info.read_error.empty()) out += "read stopped: " + common::Printable(info.read_error) + "\n";
  return out;
}

std::string JsonText(const nlohmann::json& j, int indent) {
  return j.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace);
}

nlohmann::json ToJson(const LogInfo& info) {
  nlohmann::json j;
  j["kind"] = "lcm_log";
  j["path"] = info.path;
  j["file_bytes"] = info.file_bytes;
  j["events"] = info.events;
  j["duration"] = info.duration;
  j["first_time"] = info.has_time ? JsonNumber(info.first_time) : nlohmann::json(nullptr);
  j["last_time"] = info.has_time ? JsonNumber(info.last_time) : nlohmann::json(nullptr);
  j["log_duration"] = info.log_duration;
  j["damaged_regions"] = info.damaged_regions;
  j["damaged_bytes"] = info.damaged_bytes;
  j["damaged_events"] = info.damaged_events;
  if (info.has_config) {
    nlohmann::json rig;
    rig["rig"] = info.rig;
    rig["calibration"] = info.calibration;
    rig["sample_rate_hz"] = JsonNumber(info.config_rate_hz);
    rig["channels"] = info.config_channels;
    rig["units"] = info.config_units;
    rig["sensors"] = info.config_sensors;
    rig["alpha"] = JsonNumber(info.alpha);
    rig["p"] = JsonNumber(info.p);
    rig["mu"] = JsonNumber(info.mu);
    rig["messages"] = info.config_messages;
    rig["changes"] = info.config_changes;
    j["config"] = rig;
  } else {
    j["config"] = nullptr;
  }
  j["channels"] = nlohmann::json::array();
  for (const ChannelInfo& c : info.channels) {
    nlohmann::json o;
    o["name"] = c.name;
    o["type"] = c.type;
    o["fingerprint"] = Format("0x%016" PRIx64, static_cast<std::uint64_t>(c.fingerprint));
    o["count"] = c.count;
    o["bytes"] = c.bytes;
    o["first_time"] = c.has_time ? JsonNumber(c.first_time) : nlohmann::json(nullptr);
    o["last_time"] = c.has_time ? JsonNumber(c.last_time) : nlohmann::json(nullptr);
    o["rate_hz"] = JsonNumber(c.rate_hz);
    o["seq_gaps"] = c.has_seq ? nlohmann::json(c.seq_gaps) : nlohmann::json(nullptr);
    o["seq_missing"] = c.has_seq ? nlohmann::json(c.seq_missing) : nlohmann::json(nullptr);
    o["seq_back"] = c.has_seq ? nlohmann::json(c.seq_back) : nlohmann::json(nullptr);
    o["seq_late"] = c.has_seq ? nlohmann::json(c.seq_late) : nlohmann::json(nullptr);
    o["seq_duplicates"] = c.has_seq ? nlohmann::json(c.seq_duplicates) : nlohmann::json(nullptr);
    o["seq_restarts"] = c.has_seq ? nlohmann::json(c.seq_restarts) : nlohmann::json(nullptr);
    o["seq_wild"] = c.has_seq ? nlohmann::json(c.seq_wild) : nlohmann::json(nullptr);
    o["undecodable"] = c.undecodable;
    j["channels"].push_back(o);
  }
  return j;
}

nlohmann::json ToJson(const RawInfo& info) {
  nlohmann::json j;
  j["kind"] = info.format;
  j["path"] = info.path;
  j["file_bytes"] = info.file_bytes;
  j["rows"] = info.rows;
  j["bad_rows"] = info.bad_rows;
  j["bad_values"] = info.bad_values;
  j["empty_values"] = info.empty_values;
  j["comments"] = info.comments;
  j["warnings"] = info.warnings;
  j["segments"] = info.segments;
  j["rate_hz"] = JsonNumber(info.rate_hz);
  j["measured_rate_hz"] = JsonNumber(info.measured_rate_hz);
  j["first_time"] = info.has_time ? JsonNumber(info.first_time) : nlohmann::json(nullptr);
  j["last_time"] = info.has_time ? JsonNumber(info.last_time) : nlohmann::json(nullptr);
  j["duration"] = JsonNumber(info.span);
  j["seq_gaps"] = info.seq_gaps;
  j["seq_missing"] = info.seq_missing;
  j["read_error"] = info.read_error.empty() ? nlohmann::json(nullptr) : nlohmann::json(info.read_error);
  j["channels"] = nlohmann::json::array();
  for (std::size_t i = 0; i < info.channels.size(); ++i) {
    auto text = [](const std::vector<std::string>& v, std::size_t k) {
      return k < v.size() && !v[k].empty() ? nlohmann::json(v[k]) : nlohmann::json(nullptr);
    };
    j["channels"].push_back({{"name", info.channels[i]},
                             {"unit", text(info.units, i)},
                             {"file_unit", text(info.file_units, i)},
                             {"rig_unit", text(info.rig_units, i)}});
  }
  return j;
}

}  // namespace rocklab::exporter
