// rocklab run: daq, model and compare in one process.
//
// The graph (its threading, taps, and the rule that subscription order is
// dispatch order) is pipeline::RunGraph (pipeline/run_graph.h); this file
// checks the options, builds the graph's configuration and prints the
// summary.
//
// Shutdown (SIGINT/SIGTERM set the stop flag, DaqNode::Run polls it): the
// graph stops in the order RunGraph::Run documents; the summary is printed;
// exit 0 (1 when the log could not be written or the input was a damaged
// LCM log).
#include <atomic>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/lcm_log.h"
#include "common/progress.h"
#include "common/provenance.h"
#include "compare/compare_flags.h"
#include "compare/compare_node.h"
#include "model/model_node.h"
#include "pipeline/ensemble_flags.h"
#include "pipeline/pipeline.h"
#include "pipeline/run_graph.h"
#include "tools/cli.h"

namespace rocklab::tools {
namespace {

struct RunCommand {
  std::string rig_path;
  std::string input;
  std::vector<std::string> variants;
  std::string lcm_url{"memq://"};
  std::string log_path;
  std::string summary_json;
  bool json{};
  double speed{1.0};
  bool max{};
  int lookahead{0};
  int threads{1};
  double rtol{model::ModelOptions{}.rtol};
  bool quiet{};
  compare::CompareNodeConfig compare;
  pipeline::EnsembleFlags ensemble;
};

int RunAll(RunCommand& c) {
  const daq::RigConfig rig = pipeline::LoadRig(c.rig_path);
  if (c.max) c.speed = 0;
  // As fast as possible, host time says nothing about the inputs: a host
  // stall must not make STALE/RECOVERED events (the sample clock decides).
  if (c.speed == 0) c.compare.stale_clock = compare::StaleClock::kSample;
  Require(c.speed >= 0, "--speed", ">= 0", c.speed);
  pipeline::ValidateCompareOptions(c.compare);
  RefuseStandardOutput("--log", c.log_path, "an LCM log is written to a file");
  RequireOutputFolder("--summary", c.summary_json);  // before the run, not after it (--log: RunGraph's)
  const std::atomic<bool>& stop = InstallStopSignals();

  pipeline::RunGraphConfig g;
  g.lcm_url = c.lcm_url;
  g.log_path = c.log_path;
  g.compare = c.compare;
  g.model.variants = pipeline::BuildVariants(c.variants, rig, c.rtol);
  g.model.ensembles = pipeline::BuildEnsembles(c.ensemble, c.rtol);
  // Default 0 also with --max: on accelerometer data (and on the
  // differentiated displacement) 32 took more CPU, not less
  // (docs/performance.md, "Stepping across samples in the model node").
  g.model.lookahead_samples = c.lookahead;
  g.model.threads = c.threads;
  c.input = InputFile("RAW", c.input);
  g.daq = pipeline::DaqConfigFor(rig, c.input, c.speed);
  g.daq.stop = &stop;  // a live --input (tcp://, lcm://) waiting for its header ends on SIGINT too
  // What made the log and the summary: beside the log (LOG.provenance.csv,
  // the log's bytes as every reader expects them) and in the summary. The
  // files are hashed while the run reads them (a 109 MB record took ~1 s).
  std::vector<std::string> sources = {c.rig_path, c.input, c.ensemble.samples_path};
  for (const model::VariantSpec& v : g.model.variants) {
    if (v.params_source != "theoretical" && v.params_source != "command line") sources.push_back(v.params_source);
  }
  common::ProvenanceInBackground hashing(sources);
  pipeline::RunGraph graph(g);
  pipeline::PrintVariants(g.model.variants, stderr);
  pipeline::PrintEnsembles(g.model.ensembles, c.ensemble.size, stderr);
  {
    common::FileProgress progress("run", c.input, c.quiet || c.speed != 0);  // --max only
    graph.Run(stop);
  }

  const model::ModelNode& model = graph.model();
  const common::LogWriter* log = graph.log();
  const daq::DaqNodeStats& s = graph.daq_stats();
  std::fprintf(stderr,
               "run: %lld frames, %lld table samples to the model (%lld before its start), "
               "%lld model failures, %lld bad table samples held%s\n",
               static_cast<long long>(s.frames_read), static_cast<long long>(model.table_count()),
               static_cast<long long>(model.skipped_before_start()),
               static_cast<long long>(model.failures()),
               static_cast<long long>(model.bad_table_samples()), s.stopped_early ? " (stopped)" : "");
  const std::int64_t log_errors = log ? log->write_errors() : 0;
  if (log_errors > 0) {
    // write_errors() counts events, each either in the file or lost.
    std::fprintf(stderr, "run: --log %s: %lld events could not be written and are lost (%s); %lld written\n",
                 log->path().c_str(), static_cast<long long>(log_errors), log->error().c_str(),
                 static_cast<long long>(log->events()));
  }
  if (graph.forward_errors() > 0) {
    std::fprintf(stderr, "run: %lld network publish errors\n",
                 static_cast<long long>(graph.forward_errors()));
  }
  const common::Bus& bus = graph.bus();
  if (bus.decode_error_count() > 0 || bus.handler_error_count() > 0) {
    std::fprintf(stderr, "run: %lld messages did not decode, %lld handler errors\n",
                 static_cast<long long>(bus.decode_error_count()),
                 static_cast<long long>(bus.handler_error_count()));
  }
  if (model.member_failures() > 0) {
    std::fprintf(stderr, "run: %lld ensemble members failed and left their band\n",
                 static_cast<long long>(model.member_failures()));
  }
  PrintStackAssumptions(model, "run");
  const common::Provenance provenance = hashing.Finish();
  nlohmann::json extra = {{"provenance", nlohmann::json::parse(common::ProvenanceJson(provenance))}};
  extra["provenance"]["rig"] = {{"path", c.rig_path}, {"name", rig.name}, {"calibration", rig.calibration_id}};
  if (log != nullptr) {
    auto fields = common::ProvenanceFields(provenance);
    fields.emplace_back("rig", rig.name + (rig.calibration_id.empty() ? "" : ", calibration " + rig.calibration_id));
    common::WriteProvenanceSidecarFields(c.log_path, fields);
  }
  WriteCompareResult(graph.compare(), c.json, c.summary_json, &extra);
  const int damaged = pipeline::ReportDamage(s, c.input, "run");
  return log_errors > 0 ? kFailureExit : damaged;
}

}  // namespace

void RegisterRun(CLI::App& app, CommandRun& run) {
  auto c = std::make_shared<RunCommand>();  // shared: owned by the callback
  CLI::App* cmd = app.add_subcommand("run", "daq, model and compare in one process");
  cmd->add_option("--rig", c->rig_path, "rig configuration (TOML)")->required();
  cmd->add_option("input,--input", c->input,
                  "raw input: CSV, LVM or LCM log, video:FILE (a video file, or an image pattern frames/%06d.png) "
                  "or v4l2:/dev/videoN with the rig's [camera.video] (docs/video.md)")
      ->required();
  cmd->add_option("--variant", c->variants,
                  "NAME:MODEL:PARAMS, MODEL housner|complex, PARAMS theoretical | "
                  "alpha=A,p=P,mu=M[,l=L] | FILE.json | FILE.toml (an assembly) (repeatable)");
  cmd->add_option("--lcm-url", c->lcm_url,
                  "where the channels also go (default memq://: in-process only)");
  cmd->add_option("--log", c->log_path,
                  "write every published message to this LCM log (its provenance beside it, LOG.provenance.csv)");
  cmd->add_option("--summary", c->summary_json, "end-of-run summary JSON file (- : standard output)");
  AddJsonFlag(*cmd, c->json);
  auto* speed = cmd->add_option("--speed", c->speed,
                                "sample-clock s per host s (default 1: real time); 0 = --max");
  cmd->add_flag("--max", c->max, "as fast as possible")->excludes(speed);
  cmd->add_option("--rtol", c->rtol, "the variants' relative tolerance, in (0, 1e-3] (default 1e-10)");
  cmd->add_option("--lookahead", c->lookahead,
                  "table samples the model holds before stepping one (default 0: each as it arrives)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--threads", c->threads,
                  "threads stepping the model variants (default 1; 0: one per variant up to the cores)")
      ->check(CLI::NonNegativeNumber);
  cmd->add_flag("--quiet", c->quiet, "no progress bar (--max draws one when stderr is a terminal)");
  compare::AddCompareOptions(*cmd, c->compare);
  pipeline::AddEnsembleOptions(*cmd, c->ensemble);
  cmd->callback([c, &run] { run = [c] { return RunAll(*c); }; });
}

}  // namespace rocklab::tools
