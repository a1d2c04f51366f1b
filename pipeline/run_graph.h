#pragma once
/// @file
/// The one-process graph of `rocklab run`: the DAQ, model and compare nodes
/// (the ones `rocklab daq`, `model` and `compare` run) on one
/// common::DirectBus, with the optional taps, built in the order the graph
/// needs and shut down in the order the commands document.
///
/// Threading: one thread, the caller's. DaqNode::Run reads and paces the
/// input; every message it publishes is handed synchronously to the
/// subscribed stages (RL_THETA to the comparator and the model, RL_TABLE to
/// the model, whose RL_MODEL_* go to the comparator) before Publish returns.
/// Nothing is queued between stages, so nothing is dropped between them and
/// memory does not grow with the input.
///
/// Subscription order is dispatch order: the comparator subscribes before
/// the model, so it sees an RL_THETA before the model steps with the
/// RL_TABLE that follows it. RunGraph owns that rule.
///
/// Taps: with a log path a common::LogWritingBus wraps the direct bus and
/// writes every published message as it is published (stamped with the
/// newest sample-clock utime so far, so the log replays in order at the
/// recorded pace); a URL other than memq:// gets one catch-all subscription
/// forwarding every message to an LcmBus there.

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>

#include "common/bus.h"
#include "common/direct_bus.h"
#include "common/lcm_bus.h"
#include "common/lcm_log.h"
#include "common/log_writing_bus.h"
#include "compare/compare_node.h"
#include "daq/daq_node.h"
#include "model/model_node.h"

namespace rocklab::pipeline {

/// What the graph is built from (each node's own configuration).
struct RunGraphConfig {
  std::string lcm_url{"memq://"};  ///< memq://: in-process only; else every message also goes there
  std::string log_path;            ///< non-empty: every published message to this LCM log
  compare::CompareNodeConfig compare;
  model::ModelNodeConfig model;
  daq::DaqNodeConfig daq;
};

class RunGraph {
 public:
  /// Opens the taps and builds the nodes (comparator, model, DAQ).
  /// @throws OptionError naming --lcm-url, --log or --input.
  explicit RunGraph(const RunGraphConfig& config);
  ~RunGraph();
  RunGraph(const RunGraph&) = delete;
  RunGraph& operator=(const RunGraph&) = delete;

  /// Runs the DAQ until its input ends or `stop`; it then flushes its
  /// delayed samples through the stages and publishes its last RL_HEALTH
  /// "stopped". Then the model and the comparator finish (their last
  /// RL_HEALTH "stopped", the comparator's last RL_COMPARE_*) and the log
  /// is closed. Call once.
  void Run(const std::atomic<bool>& stop);

  const daq::DaqNodeStats& daq_stats() const { return daq_->stats(); }
  const model::ModelNode& model() const { return *model_; }
  const compare::CompareNode& compare() const { return *compare_; }
  /// The bus the nodes publish on (its decode and handler error counts).
  const common::Bus& bus() const { return *bus_; }
  /// Null without a log path.
  const common::LogWriter* log() const { return log_.get(); }
  /// Messages the network tap could not publish.
  std::int64_t forward_errors() const { return forward_errors_; }

 private:
  // Declaration order is construction order: buses before the nodes on them.
  common::DirectBus direct_;
  std::unique_ptr<common::LcmBus> net_;
  std::int64_t forward_errors_{};
  common::Subscription forward_;  // direct_ -> net_
  std::unique_ptr<common::LogWriter> log_;
  std::unique_ptr<common::LogWritingBus> logged_;
  common::Bus* bus_{};
  std::unique_ptr<compare::CompareNode> compare_;
  std::unique_ptr<model::ModelNode> model_;
  std::unique_ptr<daq::DaqNode> daq_;
};

}  // namespace rocklab::pipeline
