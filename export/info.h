#pragma once
/// @file
/// `rocklab info`: what a recorded log or a raw file holds, in one read
/// (docs/export.md: the text and the JSON schema).

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace rocklab::exporter {

struct ChannelInfo {
  std::string name;
  std::string type;             ///< rocklab LCM type name, or "unknown"
  std::int64_t fingerprint{};   ///< the payload's first 8 bytes (0 when shorter)
  std::int64_t count{};         ///< events on the channel (decodable or not)
  std::int64_t bytes{};         ///< payload bytes, all events
  std::int64_t undecodable{};   ///< events of a rocklab type that do not decode
  bool has_time{false};         ///< first/last_time set (some message decoded)
  double first_time{};          ///< first sample-clock time, s (utime / 1e6)
  double last_time{};           ///< last sample-clock time, s
  double rate_hz{};             ///< (decoded - 1) / (last - first), Hz; 0 when undefined
  bool has_seq{false};          ///< the type carries a sample sequence number
  std::int64_t seq_gaps{};      ///< jumps forward by more than 1
  std::int64_t seq_missing{};   ///< sequence numbers missing in them
  std::int64_t seq_back{};      ///< steps back or repeats
  std::int64_t seq_late{};        ///< arrived after a higher number (not lost; common::SeqGaps)
  std::int64_t seq_duplicates{};  ///< arrived again
  std::int64_t seq_restarts{};    ///< a sender began again lower
  std::int64_t seq_wild{};        ///< lone numbers far from the stream's
};

struct LogInfo {
  std::string path;
  std::int64_t file_bytes{};
  std::int64_t events{};
  std::vector<ChannelInfo> channels;  ///< by name
  std::int64_t damaged_regions{}, damaged_bytes{}, damaged_events{};
  bool has_time{false};
  double first_time{}, last_time{};  ///< all decoded messages, sample clock, s
  double duration{};                 ///< last_time - first_time, s
  double log_duration{};             ///< the writer's stamps: last - first, s
  // RL_DAQ_CONFIG (the first one; config_changes counts later ones that differ)
  bool has_config{false};
  std::string rig, calibration;
  double config_rate_hz{};
  std::vector<std::string> config_channels, config_units, config_sensors;
  double alpha{}, p{}, mu{};
  std::int64_t config_messages{}, config_changes{};
};

struct RawInfo {
  std::string path;
  std::string format;  ///< "csv" or "lvm"
  std::int64_t file_bytes{};
  std::vector<std::string> channels, units;  ///< units of the values: the file's, else --rig's, "" when unknown
  std::vector<std::string> file_units;       ///< as the file states them (LVM Y_Unit_Label), "" none
  std::vector<std::string> rig_units;        ///< the rig's calibrated unit (--rig), "" none
  std::int64_t rows{};        ///< data rows delivered
  std::int64_t bad_rows{}, bad_values{}, warnings{};
  std::int64_t empty_values{};  ///< empty fields, read as NaN (not in bad_values)
  std::int64_t comments{};      ///< LVM rows with Comment text
  std::int64_t segments{};    ///< LVM segments (CSV: 1)
  double rate_hz{};           ///< the file's nominal rate, Hz
  double measured_rate_hz{};  ///< (rows - 1) / span, Hz
  bool has_time{false};
  double first_time{}, last_time{}, span{};  ///< s
  std::int64_t seq_gaps{}, seq_missing{};
  std::string read_error;     ///< why the read stopped early; empty when it ended
};

/// @throws std::runtime_error when the log cannot be opened.
LogInfo ReadLogInfo(const std::string& path);
/// `units`: channel name -> unit (from a rig file), may be empty.
/// `sample_rate_hz`, `rate_origin`: as ExportOptions' (0: the file's).
/// @throws std::runtime_error (file:line) when the file cannot be opened.
RawInfo ReadRawInfo(const std::string& path, double sample_rate_hz,
                    const std::vector<std::pair<std::string, std::string>>& units,
                    const std::string& rate_origin = "--rate");

std::string ToText(const LogInfo& info);
std::string ToText(const RawInfo& info);
nlohmann::json ToJson(const LogInfo& info);
nlohmann::json ToJson(const RawInfo& info);

/// `j` as JSON text (`indent` < 0: one line): control bytes escaped as JSON
/// does, bytes that are not well-formed UTF-8 (a log's strings may hold
/// any) replaced by U+FFFD instead of throwing.
std::string JsonText(const nlohmann::json& j, int indent = -1);

}  // namespace rocklab::exporter
