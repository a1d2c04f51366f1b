#pragma once
// The command-line options of one scenario, shared by `rocklab simulate`,
// `synth` and `demo`. What they build and run is pipeline/scenario.h.

#include <CLI/CLI.hpp>

#include "pipeline/scenario.h"

namespace rocklab::tools {

using pipeline::BuildScenario;
using pipeline::OutputFile;
using pipeline::RunScenario;
using pipeline::RunSummary;
using pipeline::Scenario;
using pipeline::ScenarioOptions;
using pipeline::WriteEventsCsv;

/// Adds --model --alpha --p --mu --theta0 --excitation --accel --duration
/// --rate --l --complex-handoff to `cmd`, storing into `options` (which must outlive parsing).
void AddScenarioOptions(CLI::App& cmd, ScenarioOptions& options);

}  // namespace rocklab::tools
