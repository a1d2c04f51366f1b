// rocklab daq --rig RIG.toml --input INPUT [--speed X | --max] [--lcm-url URL] [--raw-url URL|same]
//             [--follow] [--idle-timeout S] [--delimiter D]
//             [--log FILE [--rotate-size BYTES] [--rotate-seconds S]]
//             [--config FILE.toml] [--check]:
// the DAQ node on a recorded file (paced on its sample clock), a file being
// written (--follow), an acquisition PC's TCP stream (tcp://HOST:PORT, or
// tcp-listen://[HOST]:PORT where the PC connects) or
// another program's raw frames (lcm://CHANNEL). Threading model and
// shutdown order: daq/daq_node.h (one thread; SIGINT/SIGTERM only set the
// stop flag; what was read is published, then a final RL_HEALTH). The stage
// itself is RunDaqStage (pipeline/pipeline.h), which `rocklab replay --rig`
// runs too. --config: every option as a key (pipeline::DaqConfigKeys), the
// flags given override it; --check validates and prints what would be read.
#include <memory>
#include <string>

#include "pipeline/pipeline.h"
#include "tools/cli.h"

namespace rocklab::tools {

void RegisterDaq(CLI::App& app, CommandRun& run) {
  auto opts = std::make_shared<pipeline::DaqStageOptions>();  // shared: owned by the callback
  auto config_path = std::make_shared<std::string>();
  auto check = std::make_shared<bool>(false);
  auto json = std::make_shared<bool>(false);
  CLI::App* cmd = app.add_subcommand("daq", "DAQ node: publish a raw input's frames and reconstruction over LCM");
  cmd->add_option("--rig", opts->rig_path, "rig configuration (TOML)");
  cmd->add_option("input,--input", opts->input,
                  "raw input: .csv, .lvm or an LCM log; tcp://HOST:PORT or tcp-listen://[HOST]:PORT (CSV lines); lcm://CHANNEL (raw_frame_t); video:FILE or v4l2:/dev/videoN (docs/video.md)");
  auto* speed = cmd->add_option("--speed", opts->speed, "sample-clock pace factor (1 = real time)")
                    ->capture_default_str();
  cmd->add_flag("--max", opts->max_speed, "as fast as possible")->excludes(speed);
  cmd->add_option("--lcm-url", opts->lcm_url, "LCM URL (default: LCM_DEFAULT_URL or LCM's own)");
  AddRawUrlOption(*cmd, opts->raw_url);
  cmd->add_option("--prefix", opts->prefix, "channel prefix")->capture_default_str();
  cmd->add_flag("--follow", opts->follow, "CSV/LVM: keep reading as the file grows (and is replaced)");
  cmd->add_option("--idle-timeout", opts->idle_timeout_s, "live inputs: stop after S s without data (0 = never)");
  cmd->add_option("--delimiter", opts->delimiter, "CSV field separator: ',', ';' or tab (default: sniffed)");
  cmd->add_option("--log", opts->log_path, "also write every published message to this LCM log");
  cmd->add_option("--rotate-size", opts->rotate_bytes, "--log: start a new file before one passes BYTES");
  cmd->add_option("--rotate-seconds", opts->rotate_seconds, "--log: start a new file every S s of sample clock");
  cmd->add_option("--config", *config_path, "options as TOML keys (rig, input, ...); flags override");
  cmd->add_flag("--check", *check, "validate the options, rig and input, print what would be read, exit");
  AddJsonFlag(*cmd, *json);
  cmd->callback([opts, config_path, check, json, cmd, &run] {
    if (!config_path->empty()) {
      pipeline::ApplyDaqConfigFile(*config_path, *opts, [cmd](const std::string& key) {
        return cmd->count("--" + key) > 0;
      });
    }
    if (*check) {
      run = [opts] {
        pipeline::CheckDaqStage(*opts);
        return 0;
      };
      return;
    }
    run = [opts, json] {
      RefuseStandardOutput("--log", opts->log_path, "an LCM log is written to a file");
      opts->input = InputFile("RAW", opts->input);
      return RunDaqStageCommand(*opts, "daq", *json);
    };
  });
}

}  // namespace rocklab::tools
