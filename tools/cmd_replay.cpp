// rocklab replay: two forms.
//   rocklab replay LOG.lcm [--speed X | --max] [--channels REGEX] [--loop] [--start S] [--end S] [--lcm-url URL]
//     re-publishes a recorded log (speed, max, channel filter, loop, time window);
//   rocklab replay --rig RIG.toml --input RAW [--speed X | --max] [--lcm-url URL]
//     sends a raw file (CSV, LVM or LCM log of RL_RAW) through the DAQ stage:
//     the code path of `rocklab daq` (RunDaqStage), so it publishes what the
//     DAQ publishes.
// Both forms take [--raw-url URL|same]: RL_RAW goes on its own bus, as the
// DAQ sends it (common/bus_urls.h), every other channel on --lcm-url.
#include <cstdio>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "common/bus_urls.h"
#include "common/lcm_bus.h"
#include "common/progress.h"
#include "common/routing_bus.h"
#include "pipeline/log_replay.h"
#include "pipeline/pipeline.h"
#include "tools/cli.h"

namespace rocklab::tools {
namespace {

using pipeline::ReplayCounts;
using pipeline::ReplayLog;
using pipeline::ReplayOptions;

struct ReplayCommand {
  std::string log_path;
  ReplayOptions replay;
  std::string lcm_url;
  std::string raw_url;  ///< --raw-url (empty: derived from lcm_url)
  std::string rig_path;
  std::string input;
  // Options of the LOG form that were given (they make no sense with --rig).
  std::string log_only_given;
  bool quiet{};
  bool json{};
};

int RunLogReplay(const ReplayCommand& c) {
  try {
    c.replay.Validate();
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }
  const std::atomic<bool>& stop = InstallStopSignals();
  const std::unique_ptr<common::LcmBus> main_bus = pipeline::OpenLcmBus(c.lcm_url);
  const std::unique_ptr<common::LcmBus> raw_bus = pipeline::OpenRawBus(c.lcm_url, c.raw_url);
  std::unique_ptr<common::RoutingBus> routing;
  if (raw_bus) {
    routing = std::make_unique<common::RoutingBus>(*main_bus, *raw_bus,
                                                   common::ExactChannelRegex(common::RawChannel()));
  }
  common::Bus* bus = routing ? static_cast<common::Bus*>(routing.get()) : main_bus.get();
  ReplayCounts counts;
  try {
    common::FileProgress progress("replay", c.log_path, c.quiet || !c.replay.max_speed);
    counts = ReplayLog(c.log_path, c.replay, *bus, stop,
                       [](const std::string& problem) {
                         common::Progress::PrintAbove(2, [&problem] {
                           std::fprintf(stderr, "replay: %s\n", problem.c_str());
                         });
                       });
  } catch (const std::runtime_error& e) {
    throw UsageError(e.what());
  }
  std::fprintf(stderr, "replayed %lld events (%lld read, %lld filtered out, %lld failed) in %d pass%s\n",
               static_cast<long long>(counts.published), static_cast<long long>(counts.read),
               static_cast<long long>(counts.filtered), static_cast<long long>(counts.failed),
               counts.passes, counts.passes == 1 ? "" : "es");
  for (const auto& [channel, n] : counts.per_channel) {
    std::fprintf(stderr, "  %-28s %lld\n", channel.c_str(), static_cast<long long>(n));
  }
  if (c.json) {
    WriteResult({{"log", c.log_path},
                 {"published", counts.published},
                 {"read", counts.read},
                 {"filtered", counts.filtered},
                 {"failed", counts.failed},
                 {"passes", counts.passes},
                 {"per_channel", counts.per_channel},
                 {"damaged_regions", counts.damaged_regions},
                 {"damaged_bytes", counts.damaged_bytes},
                 {"damaged_events", counts.damaged_events}},
                true);
  }
  // Everything readable was published; the exit code says the log is damaged.
  pipeline::ReportDamage(counts.damaged_regions, counts.damaged_bytes, counts.damaged_events,
                         c.log_path, "replay", "");
  return counts.failed == 0 && counts.damaged_regions == 0 ? 0 : kFailureExit;
}

int RunReplay(const ReplayCommand& c) {
  const bool raw_form = !c.rig_path.empty() || !c.input.empty();
  if (!c.log_path.empty() && raw_form) {
    throw UsageError("replay: give either LOG.lcm (a recorded log) or --rig RIG.toml --input RAW "
                     "(a raw file through the DAQ stage), not both");
  }
  if (!raw_form) {
    if (c.log_path.empty()) {
      throw UsageError("replay: give LOG.lcm (a recorded log) or --rig RIG.toml --input RAW "
                       "(a raw file through the DAQ stage)");
    }
    RefuseStandardInput("LOG", c.log_path, "an LCM log is read by seeking in it");
    return RunLogReplay(c);
  }
  if (c.rig_path.empty()) throw UsageError("replay: --input needs --rig RIG.toml");
  if (c.input.empty()) throw UsageError("replay: --rig needs --input RAW (CSV, LVM or LCM log)");
  if (!c.log_only_given.empty()) {
    throw UsageError("replay: " + c.log_only_given +
                     " applies to LOG.lcm only, not to --rig --input (the DAQ stage plays the "
                     "whole raw file)");
  }
  pipeline::DaqStageOptions daq;
  daq.rig_path = c.rig_path;
  daq.input = InputFile("--input", c.input);
  daq.speed = c.replay.speed;
  daq.max_speed = c.replay.max_speed;
  daq.lcm_url = c.lcm_url;
  daq.raw_url = c.raw_url;
  common::FileProgress progress("replay", c.input, c.quiet || !c.replay.max_speed);
  return RunDaqStageCommand(daq, "replay", c.json);
}

}  // namespace

void RegisterReplay(CLI::App& app, CommandRun& run) {
  auto c = std::make_shared<ReplayCommand>();  // shared: owned by the callback
  CLI::App* cmd = app.add_subcommand(
      "replay", "re-publish a recorded LCM log, or send a raw file through the DAQ stage");
  cmd->add_option("log", c->log_path, "LCM log file (re-published as recorded)");
  cmd->add_option("--rig", c->rig_path, "rig configuration (TOML), with --input");
  cmd->add_option("--input", c->input, "raw file (.csv, .lvm or LCM log) for the DAQ stage, with --rig");
  auto* speed = cmd->add_option("--speed", c->replay.speed, "pace factor (1 = as recorded)");
  cmd->add_flag("--max", c->replay.max_speed, "as fast as possible")->excludes(speed);
  cmd->add_flag("--quiet", c->quiet, "no progress bar (--max draws one when stderr is a terminal)");
  AddJsonFlag(*cmd, c->json);
  cmd->add_option("--channels", c->replay.channels, "LOG only: regex of the channels to publish")
      ->capture_default_str();
  cmd->add_flag("--loop", c->replay.loop, "LOG only: start again at the end");
  cmd->add_option("--start", c->replay.start_s, "LOG only: window start, s after the first event");
  cmd->add_option("--end", c->replay.end_s, "LOG only: window end, s after the first event");
  cmd->add_option("--lcm-url", c->lcm_url, "LCM URL (default: LCM_DEFAULT_URL or LCM's own)");
  AddRawUrlOption(*cmd, c->raw_url);
  cmd->callback([c, cmd, &run] {
    c->log_only_given.clear();
    for (const char* name : {"--channels", "--loop", "--start", "--end"}) {
      if (cmd->count(name) > 0 && c->log_only_given.empty()) c->log_only_given = name;
    }
    run = [c] { return RunReplay(*c); };
  });
}

}  // namespace rocklab::tools
