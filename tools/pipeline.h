#pragma once
// The pipeline library's names as the commands use them, and the
// comparator's command-line options.

#include <CLI/CLI.hpp>

#include "pipeline/pipeline.h"

namespace rocklab::tools {

using pipeline::BuildVariants;
using pipeline::DaqConfigFor;
using pipeline::DaqStageOptions;
using pipeline::LoadRig;
using pipeline::OpenLcmBus;
using pipeline::ReportDamage;
using pipeline::RunDaqStage;
using pipeline::TheoreticalParams;
using pipeline::ValidateCompareOptions;

/// --compare-rate --window --stale options of the comparator, into `config`.
void AddCompareOptions(CLI::App& cmd, compare::CompareNodeConfig& config);

}  // namespace rocklab::tools
