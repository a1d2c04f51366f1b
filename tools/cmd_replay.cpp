// rocklab replay LOG.lcm: re-publish a recorded log (speed, max, channel
// filter, loop, time window).
#include <cstdio>
#include <memory>
#include <string>

#include <lcm/lcm-cpp.hpp>

#include "tools/cli.h"
#include "tools/log_replay.h"

namespace rocklab::tools {
namespace {

struct ReplayCommand {
  std::string log_path;
  ReplayOptions replay;
  std::string lcm_url;
};

int RunReplay(const ReplayCommand& c) {
  try {
    c.replay.Validate();
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }
  const std::atomic<bool>& stop = InstallStopSignals();
  lcm::LCM lcm(c.lcm_url);
  if (!lcm.good()) throw UsageError("--lcm-url: cannot open LCM at '" + c.lcm_url + "'");
  ReplayCounts counts;
  try {
    counts = ReplayLog(c.log_path, c.replay, lcm, stop);
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
  return counts.failed == 0 ? 0 : kFailureExit;
}

}  // namespace

void RegisterReplay(CLI::App& app, CommandRun& run) {
  auto c = std::make_shared<ReplayCommand>();  // shared: owned by the callback
  CLI::App* cmd = app.add_subcommand("replay", "re-publish a recorded LCM log");
  cmd->add_option("log", c->log_path, "LCM log file")->required();
  auto* speed = cmd->add_option("--speed", c->replay.speed, "pace factor (1 = as recorded)");
  cmd->add_flag("--max", c->replay.max_speed, "as fast as possible")->excludes(speed);
  cmd->add_option("--channels", c->replay.channels, "regex of the channels to publish")
      ->capture_default_str();
  cmd->add_flag("--loop", c->replay.loop, "start again at the end");
  cmd->add_option("--start", c->replay.start_s, "window start, s after the first event");
  cmd->add_option("--end", c->replay.end_s, "window end, s after the first event");
  cmd->add_option("--lcm-url", c->lcm_url, "LCM URL (default: LCM_DEFAULT_URL or LCM's own)");
  cmd->callback([c, &run] { run = [c] { return RunReplay(*c); }; });
}

}  // namespace rocklab::tools
