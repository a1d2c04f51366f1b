// rocklab daq --rig RIG.toml --input FILE [--speed X | --max] [--lcm-url URL]:
// the DAQ node on a recorded file, paced on its sample clock. Threading
// model and shutdown order: daq/daq_node.h (one thread; SIGINT/SIGTERM only
// set the stop flag; what was read is published, then a final RL_HEALTH).
// The stage itself is RunDaqStage (tools/pipeline.h), which `rocklab replay
// --rig` runs too.
#include <memory>

#include "tools/cli.h"
#include "tools/pipeline.h"

namespace rocklab::tools {

void RegisterDaq(CLI::App& app, CommandRun& run) {
  auto opts = std::make_shared<DaqStageOptions>();  // shared: owned by the callback
  CLI::App* cmd = app.add_subcommand("daq", "DAQ node: publish a raw file's frames and reconstruction over LCM");
  cmd->add_option("--rig", opts->rig_path, "rig configuration (TOML)")->required();
  cmd->add_option("--input", opts->input, "raw file: .csv, .lvm or an LCM log")->required();
  auto* speed = cmd->add_option("--speed", opts->speed, "sample-clock pace factor (1 = real time)")
                    ->capture_default_str();
  cmd->add_flag("--max", opts->max_speed, "as fast as possible")->excludes(speed);
  cmd->add_option("--lcm-url", opts->lcm_url, "LCM URL (default: LCM_DEFAULT_URL or LCM's own)");
  cmd->add_option("--prefix", opts->prefix, "channel prefix")->capture_default_str();
  cmd->callback([opts, &run] { run = [opts] { return RunDaqStage(*opts, "daq", InstallStopSignals()); }; });
}

}  // namespace rocklab::tools
