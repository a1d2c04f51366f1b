#pragma once
/// @file
/// The pipeline's nodes as the commands build them: their configurations
/// from the rig file and the option values, the DAQ stage on its own bus,
/// and the end-of-run damage report. Shared by `rocklab daq`, `model`,
/// `compare`, `run`, `monitor` and `replay --rig`. Errors are OptionError
/// naming the option.

#include <atomic>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "common/bus.h"
#include "common/lcm_bus.h"
#include "compare/compare_node.h"
#include "daq/daq_node.h"
#include "daq/rig_config.h"
#include "model/model_node.h"
#include "pipeline/option_error.h"

namespace rocklab::pipeline {

/// An LcmBus on `url` (empty: LCM's default).
/// @throws OptionError("--lcm-url: cannot open LCM at '<url>'").
std::unique_ptr<common::LcmBus> OpenLcmBus(const std::string& url);

/// The bus of the raw frames for the main bus `lcm_url` and `raw_url`
/// (--raw-url: empty = derived, "same", or a URL; common/bus_urls.h): an
/// LcmBus, or null when RL_RAW goes on the main bus.
/// @throws OptionError naming --raw-url (a bad URL, or one LCM cannot open).
std::unique_ptr<common::LcmBus> OpenRawBus(const std::string& lcm_url, const std::string& raw_url);

/// Loads the rig file; errors become OptionError naming file, line and key.
daq::RigConfig LoadRig(const std::string& path);

/// The block's geometric ("theoretical") parameters: alpha, p and mu from
/// the rig's width, height and chamfer (Table 1's way).
model::BlockParams TheoreticalParams(const daq::RigConfig& rig);

/// The DAQ node's configuration for `input` at `speed` (sample-clock s per
/// host s; 0 = as fast as possible). RL_DAQ_CONFIG carries alpha, p and mu:
/// the rig's where it gives them, else its geometry's (TheoreticalParams).
daq::DaqNodeConfig DaqConfigFor(const daq::RigConfig& rig, const std::string& input, double speed);

/// The DAQ stage as a command runs it on its own LCM: `rocklab daq` and
/// `rocklab replay --rig` (one code path).
struct DaqStageOptions {
  std::string rig_path;
  std::string input;        ///< file, tcp://HOST:PORT or lcm://CHANNEL
  double speed{1.0};        ///< sample-clock s per host s; > 0
  bool max_speed{};         ///< as fast as possible (speed ignored)
  std::string lcm_url;      ///< empty: LCM's default (LCM_DEFAULT_URL or its own)
  /// --raw-url: where <prefix>RAW goes; empty: derived from lcm_url, "same":
  /// the main bus (common/bus_urls.h). An lcm:// input is read on lcm_url.
  std::string raw_url;
  std::string prefix{"RL_"};
  bool follow{};            ///< CSV/LVM: keep reading as the file grows
  double idle_timeout_s{};  ///< live inputs: end after this long without data, s; 0 = never
  std::string delimiter;    ///< CSV: "," ";" "tab" (or a tab); empty = sniffed
  std::string log_path;     ///< write every published message to this LCM log (rotated series)
  int64_t rotate_bytes{};   ///< with log_path: a new file before one passes this size, bytes; 0 = never
  double rotate_seconds{};  ///< with log_path: a new file every this many s of sample clock; 0 = never
  /// Not an option of the file: where RunDaqStage copies the node's counts
  /// at the end (`--json`); null: nowhere.
  daq::DaqNodeStats* stats_out{};
};

/// The keys of a `rocklab daq --config FILE.toml`: every option of `rocklab
/// daq` by its flag's name without the dashes (rig, input, speed, max,
/// lcm-url, raw-url, prefix, follow, idle-timeout, delimiter, log, rotate-size,
/// rotate-seconds). Relative paths (rig, input, log) are taken from the
/// config file's folder.
const std::vector<std::string>& DaqConfigKeys();

/// Reads `path` into `options`, skipping the keys for which
/// `given_on_command_line(key)` is true (flags override the file).
/// @throws OptionError "FILE:LINE: key 'K' ..." for an unknown key, a value
///         of the wrong type, a TOML syntax error ("FILE:LINE: ...").
void ApplyDaqConfigFile(const std::string& path, DaqStageOptions& options,
                        const std::function<bool(const std::string& key)>& given_on_command_line);

/// `rocklab daq --check`: validates the options, the rig and the input
/// (a file is opened and its header read; tcp:// and lcm:// are only
/// parsed), and prints what would be read on stdout.
/// @throws OptionError naming what is wrong.
void CheckDaqStage(const DaqStageOptions& options);
/// Runs the DAQ node until the input ends or `stop`, then prints its
/// counts on stderr (`<what>: N frames read, ...`); returns the exit code (0;
/// 1, the command failed, when the input was a damaged LCM log: ReportDamage).
/// @throws OptionError naming the option (bad rig, input, speed or LCM URL).
int RunDaqStage(const DaqStageOptions& options, const char* what, const std::atomic<bool>& stop);

/// A damaged LCM log input: prints "<what>: <input> is damaged: N regions
/// skipped (B bytes, E events lost)" on stderr and returns 1 (the command
/// failed); an input not read to its end (DaqNodeStats::read_error): prints
/// "<what>: <error naming the file>" and returns 1; otherwise returns 0.
/// (Each region was reported with its offset as read.)
int ReportDamage(const daq::DaqNodeStats& stats, const std::string& input, const char* what);

/// The one damage line of every command that reads an LCM log: when
/// `regions` > 0 prints "<what>: <input> is damaged: N region(s) skipped
/// (B bytes, E events lost)<rest>" on stderr and returns 1; otherwise 0.
int ReportDamage(long long regions, long long bytes, long long events, const std::string& input,
                 const char* what, const char* rest);

/// Variants from `--variant NAME:MODEL:PARAMS` options; none given: Housner
/// and the complex formulation with the theoretical parameters; every one
/// with the relative tolerance `rtol` (`--rtol`, in (0, 1e-3]). Errors
/// become OptionError naming --variant or --rtol.
std::vector<model::VariantSpec> BuildVariants(const std::vector<std::string>& texts, const daq::RigConfig& rig,
                                              double rtol = model::ModelOptions{}.rtol);

/// One line per variant on `out`: its model and parameters and where they
/// came from (a stack: its bodies and its per-body message).
void PrintVariants(const std::vector<model::VariantSpec>& variants, std::FILE* out);

/// Checks the comparator's options; throws OptionError naming the option
/// (--compare-rate, --window, --stale).
void ValidateCompareOptions(const compare::CompareNodeConfig& config);

}  // namespace rocklab::pipeline
