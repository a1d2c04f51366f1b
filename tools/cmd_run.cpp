// rocklab run: daq, model and compare in one process.
//
// Threading model: one thread, the caller's. DaqNode::Run reads and paces the
// input; its observers hand each RL_TABLE / RL_THETA message straight to the
// model and the comparator, and the model's observer hands each RL_MODEL
// message to the comparator: the stages are connected by direct calls, so the
// offline path pays no LCM dispatch per sample per stage and nothing is
// queued between stages.
//
// LCM is a tap: every node publishes on an in-process memq:// bus. With no
// --log and no network URL nobody subscribes, and memq drops each message at
// publish. With --log or a udpm:// URL, one catch-all subscription on the bus
// writes each message to the log (timestamp = the message's utime, so the log
// replays at the recorded pace) and forwards it to the network; the bus is
// drained after every table and theta sample, so it holds a handful of
// messages at most whatever the input's length.
//
// Shutdown (SIGINT/SIGTERM set the stop flag, DaqNode::Run polls it): the DAQ
// stops reading, flushes its delayed samples through the stages and publishes
// its last RL_HEALTH "stopped"; then the model and the comparator finish
// (their last RL_HEALTH "stopped", the comparator's last RL_COMPARE_*), the
// bus is drained and the log closed; the summary is printed; exit 0.
#include <atomic>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

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
  compare::CompareNodeConfig compare;
};

bool IsMemq(const std::string& url) { return url.rfind("memq://", 0) == 0; }

// The in-process bus and what listens to it: the log and the network.
class Tap {
 public:
  Tap(const std::string& url, const std::string& log_path) {
    if (!bus_.good()) throw std::runtime_error("cannot open LCM memq://");
    if (!IsMemq(url)) {
      net_ = std::make_unique<lcm::LCM>(url);
      if (!net_->good()) throw UsageError("--lcm-url: cannot open LCM at '" + url + "'");
    }
    if (!log_path.empty()) {
      log_ = std::make_unique<lcm::LogFile>(log_path, "w");
      if (!log_->good()) throw UsageError("--log: cannot write '" + log_path + "'");
    }
    if (net_ || log_) subscription_ = bus_.subscribe(".*", &Tap::OnMessage, this);
  }
  ~Tap() {
    if (subscription_) bus_.unsubscribe(subscription_);
  }
  Tap(const Tap&) = delete;
  Tap& operator=(const Tap&) = delete;

  lcm::LCM* bus() { return &bus_; }

  /// Dispatches every message waiting on the bus (none when nobody listens).
  void Drain() {
    if (!subscription_) return;
    while (bus_.handleTimeout(0) > 0) {
    }
  }

  std::int64_t log_errors() const { return log_errors_; }
  std::int64_t forward_errors() const { return forward_errors_; }

 private:
  void OnMessage(const lcm::ReceiveBuffer* rbuf, const std::string& channel) {
    if (log_) {
      // Every rocklab type starts with its 8-byte fingerprint, then
      // int64_t utime (big-endian): the log is stamped with the sample clock.
      std::int64_t utime = 0;
      if (rbuf->data_size >= 16) {
        const auto* b = static_cast<const std::uint8_t*>(rbuf->data) + 8;
        std::uint64_t u = 0;
        for (int i = 0; i < 8; ++i) u = (u << 8) | b[i];
        utime = static_cast<std::int64_t>(u);
      }
      lcm::LogEvent ev{};
      ev.eventnum = event_number_++;
      ev.timestamp = utime;
      ev.channel = channel;
      ev.datalen = static_cast<std::int32_t>(rbuf->data_size);
      ev.data = rbuf->data;
      if (log_->writeEvent(&ev) != 0) ++log_errors_;
    }
    if (net_ && net_->publish(channel, rbuf->data, rbuf->data_size) != 0) ++forward_errors_;
  }

  lcm::LCM bus_{"memq://"};
  std::unique_ptr<lcm::LCM> net_;
  std::unique_ptr<lcm::LogFile> log_;
  lcm::Subscription* subscription_{};
  std::int64_t event_number_{}, log_errors_{}, forward_errors_{};
};

int RunAll(RunCommand& c) {
  const daq::RigConfig rig = LoadRig(c.rig_path);
  if (c.max) c.speed = 0;
  Require(c.speed >= 0, "--speed", ">= 0", c.speed);
  ValidateCompareOptions(c.compare);
  const std::atomic<bool>& stop = InstallStopSignals();
  Tap tap(c.lcm_url, c.log_path);

  compare::CompareNode compare(c.compare, tap.bus());

  model::ModelNodeConfig model_cfg;
  model_cfg.variants = BuildVariants(c.variants, rig);
  model_cfg.on_state = [&compare](const rocklab::model_state_t& m) { compare.HandleModel(m); };
  model::ModelNode model(model_cfg, tap.bus());

  daq::DaqNodeConfig daq_cfg = DaqConfigFor(rig, c.input, c.speed);
  daq_cfg.on_theta = [&](const rocklab::block_state_t& theta) {
    compare.HandleTheta(theta);
    compare.CheckStale();
    model.HandleTheta(theta);
    tap.Drain();
  };
  daq_cfg.on_table = [&](const rocklab::table_state_t& table) {
    model.HandleTable(table);
    tap.Drain();
  };
  std::unique_ptr<daq::DaqNode> daq;
  try {
    daq = std::make_unique<daq::DaqNode>(daq_cfg, tap.bus());
  } catch (const std::exception& e) {
    throw UsageError(std::string("--input: ") + e.what());
  }
  for (const model::VariantSpec& v : model_cfg.variants) {
    std::fprintf(stderr, "variant %s: %s, alpha %.4f rad, p %.4f rad/s, mu %.4f (%s)\n",
                 v.name.c_str(), model::ToString(v.kind), v.params.alpha, v.params.p, v.params.mu,
                 v.params_source.c_str());
  }
  daq->Run(stop);
  model.Finish();
  compare.Finish();
  tap.Drain();

  const daq::DaqNodeStats& s = daq->stats();
  std::fprintf(stderr,
               "run: %lld frames, %lld table samples to the model (%lld before its start), "
               "%lld model failures%s\n",
               static_cast<long long>(s.frames_read), static_cast<long long>(model.table_count()),
               static_cast<long long>(model.skipped_before_start()),
               static_cast<long long>(model.failures()), s.stopped_early ? " (stopped)" : "");
  if (tap.log_errors() > 0 || tap.forward_errors() > 0) {
    std::fprintf(stderr, "run: %lld log write errors, %lld network publish errors\n",
                 static_cast<long long>(tap.log_errors()),
                 static_cast<long long>(tap.forward_errors()));
  }
  const auto summary = compare.Summary();
  compare::CompareNode::PrintSummary(summary, stdout);
  if (!c.summary_json.empty()) compare::CompareNode::WriteSummaryJson(summary, c.summary_json);
  return tap.log_errors() > 0 ? kFailureExit : 0;
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
  AddCompareOptions(*cmd, c->compare);
  cmd->callback([c, &run] { run = [c] { return RunAll(*c); }; });
}

}  // namespace rocklab::tools
