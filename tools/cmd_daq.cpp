// rocklab daq --rig RIG.toml --input FILE [--speed X | --max] [--lcm-url URL]:
// the DAQ node on a recorded file, paced on its sample clock. Threading
// model and shutdown order: daq/daq_node.h (one thread; SIGINT/SIGTERM only
// set the stop flag; what was read is published, then a final RL_HEALTH).
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>

#include "daq/daq_node.h"
#include "tools/cli.h"
#include "tools/pipeline.h"

namespace rocklab::tools {
namespace {

struct DaqOptions {
  std::string rig_path;
  std::string input;
  double speed{1.0};
  bool max_speed{};
  std::string lcm_url;
  std::string prefix{"RL_"};
};

int RunDaq(const DaqOptions& o) {
  Require(std::isfinite(o.speed) && o.speed > 0, "--speed", "> 0", o.speed);
  daq::DaqNodeConfig config;
  config.rig = LoadRig(o.rig_path);
  // RL_DAQ_CONFIG carries alpha, p and mu: from the rig, else its geometry.
  const model::BlockParams theory = TheoreticalParams(config.rig);
  if (!config.rig.block.alpha) config.rig.block.alpha = theory.alpha;
  if (!config.rig.block.p) config.rig.block.p = theory.p;
  if (!config.rig.block.mu) config.rig.block.mu = theory.mu;
  config.input = o.input;
  config.speed = o.max_speed ? 0.0 : o.speed;
  config.lcm_url = o.lcm_url;
  config.prefix = o.prefix;
  const std::atomic<bool>& stop = InstallStopSignals();
  std::unique_ptr<daq::DaqNode> node;
  try {
    node = std::make_unique<daq::DaqNode>(config);
  } catch (const std::exception& e) {
    throw UsageError(e.what());  // names the input file (and line) or the LCM URL
  }
  node->Run(stop);
  const daq::DaqNodeStats& s = node->stats();
  std::fprintf(stderr,
               "daq: %lld frames read, %lld messages published (%lld failed), %lld gaps "
               "(%lld samples missing), %lld bad samples%s\n",
               static_cast<long long>(s.frames_read), static_cast<long long>(s.published),
               static_cast<long long>(s.publish_errors), static_cast<long long>(s.gaps),
               static_cast<long long>(s.missing), static_cast<long long>(s.bad_samples),
               s.stopped_early ? ", stopped by signal" : "");
  return 0;
}

}  // namespace

void RegisterDaq(CLI::App& app, CommandRun& run) {
  auto opts = std::make_shared<DaqOptions>();  // shared: owned by the callback
  CLI::App* cmd = app.add_subcommand("daq", "DAQ node: publish a raw file's frames and reconstruction over LCM");
  cmd->add_option("--rig", opts->rig_path, "rig configuration (TOML)")->required();
  cmd->add_option("--input", opts->input, "raw file: .csv, .lvm or an LCM log")->required();
  auto* speed = cmd->add_option("--speed", opts->speed, "sample-clock pace factor (1 = real time)")
                    ->capture_default_str();
  cmd->add_flag("--max", opts->max_speed, "as fast as possible")->excludes(speed);
  cmd->add_option("--lcm-url", opts->lcm_url, "LCM URL (default: LCM_DEFAULT_URL or LCM's own)");
  cmd->add_option("--prefix", opts->prefix, "channel prefix")->capture_default_str();
  cmd->callback([opts, &run] { run = [opts] { return RunDaq(*opts); }; });
}

}  // namespace rocklab::tools
