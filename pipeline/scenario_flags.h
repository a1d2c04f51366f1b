#pragma once
/// @file
/// The command-line flags of one scenario, shared by `rocklab simulate`,
/// `synth` and `demo`: they fill a ScenarioOptions. What a scenario builds
/// and runs is pipeline/scenario.h.

#include <string>

#include "pipeline/scenario.h"

namespace CLI {
class App;
}

namespace rocklab::pipeline {

/// Adds --model --alpha --p --mu --theta0 --excitation --accel --duration
/// --rate --l --rtol --complex-handoff to `cmd`, storing into `options`
/// (which must outlive parsing). `accel_formats` ends --accel's help: the
/// formats a ground-motion record may come in (the command line's table).
void AddScenarioOptions(CLI::App& cmd, ScenarioOptions& options,
                        const std::string& accel_formats = "CSV with header time,accel (s, m/s^2)");

/// Seconds simulated after an --accel record's last sample when --duration
/// is not given: the free rocking after the shaking (`rocklab sweep`'s
/// sweep::Plan::kDefaultTail_s, the same 10 s).
inline constexpr double kDefaultTail_s = 10.0;

/// After parsing `cmd`: without --duration, sets options.duration_s to the
/// --accel record's last time + kDefaultTail_s (as `rocklab sweep` does).
/// @throws OptionError naming --duration (no --accel either) or --accel (a
///   bad record: FILE:LINE).
void ResolveDuration(const CLI::App& cmd, ScenarioOptions& options);

}  // namespace rocklab::pipeline
