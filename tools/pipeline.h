#pragma once
// Builds the pipeline nodes' configurations from the rig file and the
// command line, shared by `rocklab daq`, `model`, `compare`, `run` and
// `replay --rig`.

#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "compare/compare_node.h"
#include "daq/daq_node.h"
#include "daq/rig_config.h"
#include "model/model_node.h"

namespace rocklab::tools {

/// Loads the rig file; errors become UsageError naming file, line and key.
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
  std::string input;
  double speed{1.0};        ///< sample-clock s per host s; > 0
  bool max_speed{};         ///< as fast as possible (speed ignored)
  std::string lcm_url;      ///< empty: LCM's default (LCM_DEFAULT_URL or its own)
  std::string prefix{"RL_"};
};
/// Runs the DAQ node until the input ends or SIGINT/SIGTERM, then prints its
/// counts on stderr (`<what>: N frames read, ...`); returns the exit code (0).
/// @throws UsageError naming the option (bad rig, input, speed or LCM URL).
int RunDaqStage(const DaqStageOptions& options, const char* what);

/// Variants from `--variant NAME:MODEL:PARAMS` options; none given: Housner
/// and the complex formulation with the theoretical parameters. Errors
/// become UsageError naming --variant.
std::vector<model::VariantSpec> BuildVariants(const std::vector<std::string>& texts,
                                              const daq::RigConfig& rig);

/// --window --rate --stale options of the comparator, into `config`.
void AddCompareOptions(CLI::App& cmd, compare::CompareNodeConfig& config);
/// Checks them; throws UsageError naming the option.
void ValidateCompareOptions(const compare::CompareNodeConfig& config);

}  // namespace rocklab::tools
