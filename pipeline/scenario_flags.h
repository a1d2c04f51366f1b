#pragma once
/// @file
/// The command-line flags of one scenario, shared by `rocklab simulate`,
/// `synth` and `demo`: they fill a ScenarioOptions. What a scenario builds
/// and runs is pipeline/scenario.h.

#include "pipeline/scenario.h"

namespace CLI {
class App;
}

namespace rocklab::pipeline {

/// Adds --model --alpha --p --mu --theta0 --excitation --accel --duration
/// --rate --l --rtol --complex-handoff to `cmd`, storing into `options`
/// (which must outlive parsing).
void AddScenarioOptions(CLI::App& cmd, ScenarioOptions& options);

}  // namespace rocklab::pipeline
