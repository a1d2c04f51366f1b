// rocklab model: the model node (RL_TABLE + RL_THETA in, RL_MODEL_<name> out).
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "common/lcm_bus.h"
#include "model/model_node.h"
#include "pipeline/ensemble_flags.h"
#include "pipeline/pipeline.h"
#include "tools/cli.h"

namespace rocklab::tools {
namespace {

struct ModelCommand {
  std::string rig_path;
  std::vector<std::string> variants;
  std::string lcm_url;
  int lookahead{0};
  int threads{1};
  double rtol{model::ModelOptions{}.rtol};
  pipeline::EnsembleFlags ensemble;
};

int RunModel(const ModelCommand& c) {
  const daq::RigConfig rig = pipeline::LoadRig(c.rig_path);
  model::ModelNodeConfig cfg;
  cfg.variants = pipeline::BuildVariants(c.variants, rig, c.rtol);
  cfg.ensembles = pipeline::BuildEnsembles(c.ensemble, c.rtol);
  cfg.lookahead_samples = c.lookahead;
  cfg.threads = c.threads;
  const std::atomic<bool>& stop = InstallStopSignals();
  const std::string url = SubscriberUrl(c.lcm_url);
  const std::unique_ptr<common::LcmBus> bus = pipeline::OpenLcmBus(url);
  model::ModelNode node(cfg, *bus);
  pipeline::PrintVariants(cfg.variants, stderr);
  pipeline::PrintEnsembles(cfg.ensembles, c.ensemble.size, stderr);
  node.Run(stop);
  std::fprintf(stderr, "model: %lld table samples, %lld before the start, %lld resets, %lld failures\n",
               static_cast<long long>(node.table_count()),
               static_cast<long long>(node.skipped_before_start()),
               static_cast<long long>(node.resets()), static_cast<long long>(node.failures()));
  PrintStackAssumptions(node, "model");
  return 0;
}

}  // namespace

void RegisterModel(CLI::App& app, CommandRun& run) {
  auto c = std::make_shared<ModelCommand>();  // shared: owned by the callback
  CLI::App* cmd = app.add_subcommand("model", "run model variants beside the experiment (LCM node)");
  cmd->add_option("--rig", c->rig_path, "rig configuration (TOML)")->required();
  cmd->add_option("--variant", c->variants,
                  "NAME:MODEL:PARAMS, MODEL housner|complex, PARAMS theoretical | "
                  "alpha=A,p=P,mu=M[,l=L] | FILE.json | FILE.toml (an assembly) (repeatable)");
  cmd->add_option("--lcm-url", c->lcm_url, "LCM URL (default: LCM_DEFAULT_URL or LCM's own)");
  cmd->add_option("--lookahead", c->lookahead,
                  "table samples held before one is stepped (default 0: each as it arrives; N > 0 "
                  "integrates across samples, N sample periods later)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--rtol", c->rtol, "the variants' relative tolerance, in (0, 1e-3] (default 1e-10)");
  cmd->add_option("--threads", c->threads,
                  "threads stepping the variants (default 1; 0: one per variant up to the cores)")
      ->check(CLI::NonNegativeNumber);
  pipeline::AddEnsembleOptions(*cmd, c->ensemble);
  cmd->callback([c, &run] { run = [c] { return RunModel(*c); }; });
}

}  // namespace rocklab::tools
