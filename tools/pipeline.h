#pragma once
// Builds the pipeline nodes' configurations from the rig file and the
// command line, shared by `rocklab model`, `rocklab compare` and `rocklab run`.

#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "compare/compare_node.h"
#include "daq/rig_config.h"
#include "model/model_node.h"

namespace rocklab::tools {

/// Loads the rig file; errors become UsageError naming file, line and key.
daq::RigConfig LoadRig(const std::string& path);

/// The block's geometric ("theoretical") parameters: alpha, p and mu from
/// the rig's width, height and chamfer (Table 1's way).
model::BlockParams TheoreticalParams(const daq::RigConfig& rig);

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
