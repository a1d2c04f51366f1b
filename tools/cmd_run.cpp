// rocklab run: daq, model and compare in one process.
//
// Threading model: one thread, the caller's. The three nodes are the ones
// `rocklab daq`, `model` and `compare` run, on a common::DirectBus: the
// DaqNode's Run reads and paces the input, and every message it publishes is
// handed synchronously to the subscribed stages (RL_THETA to the comparator
// and the model, RL_TABLE to the model, whose RL_MODEL_* go to the
// comparator) before Publish returns. Nothing is queued between stages, so
// nothing can be dropped between them and memory does not grow with the input.
//
// Taps: with --log a common::LogWritingBus wraps the direct bus and writes
// every published message to the log as it is published (stamped with the
// newest sample-clock utime so far: the stamps never go back, so the log
// replays in order at the recorded pace); with a udpm:// URL one catch-all
// subscription on the direct bus forwards every message to the network.
//
// Shutdown (SIGINT/SIGTERM set the stop flag, DaqNode::Run polls it): the DAQ
// stops reading, flushes its delayed samples through the stages and publishes
// its last RL_HEALTH "stopped"; then the model and the comparator finish
// (their last RL_HEALTH "stopped", the comparator's last RL_COMPARE_*); the
// log is closed; the summary is printed; exit 0 (1 when the log could not be
// written or the input was a damaged LCM log).
#include <atomic>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "common/lcm_log.h"
#include "common/progress.h"
#include "compare/compare_node.h"
#include "daq/daq_node.h"
#include "model/model_node.h"
#include "tools/cli.h"
#include "tools/pipeline.h"

namespace rocklab::tools {
namespace {

struct RunCommand {
  std::string rig_path;
  std::string input;
  std::vector<std::string> variants;
  std::string lcm_url{"memq://"};
  std::string log_path;
  std::string summary_json;
  double speed{1.0};
  bool max{};
  int lookahead{0};
  int threads{1};
  double rtol{model::ModelOptions{}.rtol};
  bool quiet{};
  compare::CompareNodeConfig compare;
};

bool IsMemq(const std::string& url) { return url.rfind("memq://", 0) == 0; }

int RunAll(RunCommand& c) {
  const daq::RigConfig rig = LoadRig(c.rig_path);
  if (c.max) c.speed = 0;
  // As fast as possible, host time says nothing about the inputs: a host
  // stall must not make STALE/RECOVERED events (the sample clock decides).
  if (c.speed == 0) c.compare.stale_clock = compare::StaleClock::kSample;
  Require(c.speed >= 0, "--speed", ">= 0", c.speed);
  ValidateCompareOptions(c.compare);
  const std::atomic<bool>& stop = InstallStopSignals();
  common::DirectBus direct;
  std::unique_ptr<common::LcmBus> net;
  std::int64_t forward_errors = 0;
  if (!IsMemq(c.lcm_url)) {
    net = OpenLcmBus(c.lcm_url);
    direct.SubscribeRaw(".*", [&net, &forward_errors](const std::string& channel, const void* data, int size) {
      if (!net->Publish(channel, data, size)) ++forward_errors;
    });
  }
  std::unique_ptr<common::LogWriter> log;
  std::unique_ptr<common::LogWritingBus> logged;
  if (!c.log_path.empty()) {
    try {
      log = std::make_unique<common::LogWriter>(c.log_path);
    } catch (const std::runtime_error&) {
      throw UsageError("--log: cannot write '" + c.log_path + "'");
    }
    logged = std::make_unique<common::LogWritingBus>(direct, *log);
  }
  common::Bus& bus = logged ? static_cast<common::Bus&>(*logged) : direct;

  // Subscription order is dispatch order: the comparator sees an RL_THETA
  // before the model steps with the RL_TABLE that follows it.
  compare::CompareNode compare(c.compare, bus);
  model::ModelNodeConfig model_cfg;
  model_cfg.variants = BuildVariants(c.variants, rig, c.rtol);
  // Default 0 also with --max: on accelerometer data (and on the
  // differentiated displacement) 32 took more CPU, not less
  // (docs/performance.md, "Stepping across samples in the model node").
  model_cfg.lookahead_samples = c.lookahead;
  model_cfg.threads = c.threads;
  model::ModelNode model(model_cfg, bus);
  daq::DaqNodeConfig daq_cfg = DaqConfigFor(rig, c.input, c.speed);
  daq_cfg.stop = &stop;  // a live --input (tcp://, lcm://) waiting for its header ends on SIGINT too
  std::unique_ptr<daq::DaqNode> daq;
  try {
    daq = std::make_unique<daq::DaqNode>(daq_cfg, bus);
  } catch (const std::exception& e) {
    throw UsageError(std::string("--input: ") + e.what());
  }
  for (const model::VariantSpec& v : model_cfg.variants) {
    std::fprintf(stderr, "variant %s: %s, alpha %.4f rad, p %.4f rad/s, mu %.4f (%s)\n",
                 v.name.c_str(), model::ToString(v.kind), v.params.alpha, v.params.p, v.params.mu,
                 v.params_source.c_str());
  }
  {
    common::FileProgress progress("run", c.input, c.quiet || c.speed != 0);  // --max only
    daq->Run(stop);
  }
  model.Finish();
  compare.Finish();
  if (log) log->Close();

  const daq::DaqNodeStats& s = daq->stats();
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
  if (forward_errors > 0) {
    std::fprintf(stderr, "run: %lld network publish errors\n", static_cast<long long>(forward_errors));
  }
  if (bus.decode_error_count() > 0 || bus.handler_error_count() > 0) {
    std::fprintf(stderr, "run: %lld messages did not decode, %lld handler errors\n",
                 static_cast<long long>(bus.decode_error_count()),
                 static_cast<long long>(bus.handler_error_count()));
  }
  const auto summary = compare.Summary();
  compare::CompareNode::PrintSummary(summary, stdout);
  if (!c.summary_json.empty()) compare::CompareNode::WriteSummaryJson(summary, c.summary_json);
  const int damaged = ReportDamage(s, c.input, "run");
  return log_errors > 0 ? kFailureExit : damaged;
}

}  // namespace

void RegisterRun(CLI::App& app, CommandRun& run) {
  auto c = std::make_shared<RunCommand>();  // shared: owned by the callback
  CLI::App* cmd = app.add_subcommand("run", "daq, model and compare in one process");
  cmd->add_option("--rig", c->rig_path, "rig configuration (TOML)")->required();
  cmd->add_option("--input", c->input, "raw input: CSV, LVM or LCM log")->required();
  cmd->add_option("--variant", c->variants,
                  "NAME:MODEL:PARAMS, MODEL housner|complex, PARAMS theoretical | "
                  "alpha=A,p=P,mu=M[,l=L] | FILE.json (repeatable)");
  cmd->add_option("--lcm-url", c->lcm_url,
                  "where the channels also go (default memq://: in-process only)");
  cmd->add_option("--log", c->log_path, "write every published message to this LCM log");
  cmd->add_option("--summary", c->summary_json, "end-of-run summary JSON file");
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
  AddCompareOptions(*cmd, c->compare);
  cmd->callback([c, &run] { run = [c] { return RunAll(*c); }; });
}

}  // namespace rocklab::tools
