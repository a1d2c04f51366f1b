#pragma once
// `rocklab simulate --assembly FILE.toml`: the option, its checks against
// the single block's options, and the run written as CSV and summary
// (pipeline/assembly.h runs it; docs/commands.md, "simulate --assembly").
#include <string>

#include "pipeline/scenario.h"

namespace CLI {
class App;
}

namespace rocklab::tools {

/// Adds --assembly (into `path`) to simulate's `cmd`, whose --alpha, --p
/// and --mu then are required only without it (CheckAssemblyOptions).
void AddAssemblyOption(CLI::App& cmd, std::string& path);

/// After parsing: without --assembly, --alpha, --p and --mu are required;
/// with it, none of them nor --theta0 may be given. @throws UsageError.
void CheckAssemblyOptions(const CLI::App& cmd, const std::string& path);

/// Writes `time,theta_1,theta_dot_1,...,mode` to `out_csv` (and the events,
/// `time,kind,interface,body,mode`, to `events_csv` when not empty) and
/// prints the summary (as JSON with `json`). Returns the exit code.
int RunSimulateAssembly(const pipeline::ScenarioOptions& scenario, const std::string& path,
                        const std::string& out_csv, const std::string& events_csv, bool json);

}  // namespace rocklab::tools
