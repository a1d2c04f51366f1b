// rocklab compare: the comparator node (RL_THETA + RL_MODEL_* in,
// RL_COMPARE_<name> out), with a summary at the end.
#include <cstdio>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "common/lcm_bus.h"
#include "common/provenance.h"
#include "compare/compare_flags.h"
#include "compare/compare_node.h"
#include "pipeline/pipeline.h"
#include "tools/cli.h"

namespace rocklab::tools {
namespace {

struct CompareCommand {
  compare::CompareNodeConfig config;
  std::string lcm_url;
  std::string summary_json;
  bool json{};
};

int RunCompare(CompareCommand& c) {
  pipeline::ValidateCompareOptions(c.config);
  RequireOutputFolder("--summary", c.summary_json);  // before the node runs, not at its stop
  const std::atomic<bool>& stop = InstallStopSignals();
  const std::unique_ptr<common::LcmBus> bus = pipeline::OpenLcmBus(SubscriberUrl(c.lcm_url));
  compare::CompareNode node(c.config, *bus);
  node.Run(stop);
  // What made the summary: a live node reads no file, so no sources; the
  // bus it listened to says where its data came from.
  nlohmann::json extra = {{"provenance", nlohmann::json::parse(common::ProvenanceJson(common::MakeProvenance({})))}};
  extra["provenance"]["lcm_url"] = c.lcm_url;
  WriteCompareResult(node, c.json, c.summary_json, &extra);
  return 0;
}

}  // namespace

void RegisterCompare(CLI::App& app, CommandRun& run) {
  auto c = std::make_shared<CompareCommand>();  // shared: owned by the callback
  CLI::App* cmd = app.add_subcommand("compare", "live error between experiment and models (LCM node)");
  compare::AddCompareOptions(*cmd, c->config);
  cmd->add_option("--summary", c->summary_json, "end-of-run summary JSON file (- : standard output)");
  AddJsonFlag(*cmd, c->json);
  cmd->add_option("--lcm-url", c->lcm_url, "LCM URL (default: LCM_DEFAULT_URL or LCM's own)");
  cmd->callback([c, &run] { run = [c] { return RunCompare(*c); }; });
}

}  // namespace rocklab::tools
