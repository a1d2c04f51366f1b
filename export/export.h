#pragma once
/// @file
/// `rocklab export`: an LCM log (rocklab's or lcm-logger's) or a raw CSV /
/// LVM file into CSV, MAT or HDF5 tables (docs/export.md).
///
/// From a log: one table per selected channel (named by the channel; a
/// channel that changes type gets a second table CHANNEL_<type>), one row
/// per message that decodes, every field by its type (export/fields.h).
/// A raw_frame_t table also gets a column per channel named after the
/// rig's channel (from the log's daq_config_t): raw values, or calibrated
/// ones with ExportOptions::calibrated; values_0.. stay as they were.
/// From a raw file: one table `data`, `time` (s) then the channels by their
/// names (units: the file's, else the rig's), NaN where a value is
/// missing, and a text column `comment` when an LVM has a Comment column.
/// Both stream: rows go to the sink as
/// they are read.
///
/// The window: --start/--end in s from the record's first sample (a log:
/// the sample-clock utime of its first rocklab message; a raw file: its
/// first row's time). Rows outside are counted, not written.

#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "export/table.h"

namespace rocklab::exporter {

/// The input cannot be opened or read from its start (the message names
/// the file); what the sink throws stays a std::runtime_error.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct ExportOptions {
  std::string channels{".*"};  ///< ECMAScript regex over whole channel names (logs)
  double start_s{0.0};         ///< s from the first sample; >= 0
  /// s from the first sample, >= start_s; infinity (the default): to the
  /// end. A negative end is refused, not read as "to the end".
  double end_s{std::numeric_limits<double>::infinity()};
  /// Raw files: the sample rate, Hz; 0 = the file's time column or time
  /// base (a file without one needs it); given and the file's disagreeing
  /// by more than 0.1 %, the file is refused (daq::SourceOptions).
  double sample_rate_hz{};
  std::string rate_origin{"--rate"};  ///< where sample_rate_hz came from (messages)
  /// Raw files: units of the channels by name (from a rig file); others "".
  /// A unit the file states itself (LVM Y_Unit_Label) is the one used.
  std::vector<std::pair<std::string, std::string>> units;
  /// Logs: RL_RAW's channel-named columns hold gain * raw + offset in the
  /// channel's unit (RL_DAQ_CONFIG) instead of the raw values.
  bool calibrated{false};
  /// @throws std::invalid_argument naming the option.
  void Validate() const;
};

/// The rate to read a raw file at and where it came from: `rate_hz` (the
/// option `rate_name`) where > 0, else `rig_rate_hz` where a rig is given
/// (`rig_path` not empty), else 0 (the file's time column decides).
struct RawRate {
  double hz{};
  std::string origin;
};
RawRate ChooseRawRate(double rate_hz, const std::string& rate_name, double rig_rate_hz, const std::string& rig_path);

struct ChannelSummary {
  std::string channel;
  std::string type;  ///< LCM type name
  std::int64_t rows{};
  std::int64_t reshaped{};  ///< rows whose arrays were cut or padded to the first message's length
};

struct ExportSummary {
  std::vector<ChannelSummary> tables;  ///< in the order the tables were created
  std::int64_t rows{};                 ///< rows written, all tables
  std::int64_t outside_window{};       ///< messages / rows left out by --start/--end
  std::int64_t filtered{};             ///< log events of channels --channels left out
  std::int64_t unknown_type{};         ///< selected log events whose fingerprint is not a rocklab type
  std::int64_t undecodable{};          ///< selected log events of a rocklab type that did not decode
  std::int64_t damaged_regions{}, damaged_bytes{}, damaged_events{};  ///< logs (common::LogReader)
  std::int64_t bad_rows{}, bad_values{};  ///< raw files (daq::SourceStats)
  std::int64_t empty_values{};            ///< raw files: empty fields, written as NaN
  std::int64_t comments{};                ///< raw files: rows written with their LVM Comment text
  std::string read_error;  ///< raw files: why the read stopped early; empty when it ended
};

/// The sink for `out` by its extension: .csv (CsvWriter; single_table: the
/// one table into `out`), .mat (MatWriter), .h5 / .hdf5 (H5Writer).
/// @throws std::invalid_argument for another extension; std::runtime_error
///         when the file cannot be created.
std::unique_ptr<TableSink> OpenSink(const std::string& out, bool single_table);

/// Whether `path` is an LCM log (starts with the sync word) rather than a
/// raw CSV/LVM file.
bool IsLcmLog(const std::string& path);

/// A log's selected channels into `sink`. `on_problem` gets one line per
/// damaged region and per first undecodable message of a channel.
/// @throws InputError when the log cannot be opened; what the sink throws.
ExportSummary ExportLog(const std::string& path, const ExportOptions& options, TableSink& sink,
                        const std::function<void(const std::string&)>& on_problem = {});

/// A raw CSV/LVM file (the DAQ's sources) into one table `data` of `sink`.
/// @throws InputError when the file cannot be opened (file:line); what the
///         sink throws.
ExportSummary ExportRaw(const std::string& path, const ExportOptions& options, TableSink& sink,
                        const std::function<void(const std::string&)>& on_problem = {});

}  // namespace rocklab::exporter
