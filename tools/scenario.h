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

/// Seconds simulated after an --accel record's last sample when --duration
/// is not given: the free rocking after the shaking (`rocklab sweep`'s
/// sweep::Plan::kDefaultTail_s, the same 10 s).
inline constexpr double kDefaultTail_s = 10.0;

/// After parsing `cmd`: without --duration, sets options.duration_s to the
/// --accel record's last time + kDefaultTail_s (as `rocklab sweep` does).
/// @throws UsageError naming --duration (no --accel either) or --accel (a
///   bad record: FILE:LINE).
void ResolveDuration(const CLI::App& cmd, ScenarioOptions& options);

}  // namespace rocklab::tools
