#pragma once
/// @file
/// The model node: runs one or more model variants beside the experiment.
/// It subscribes RL_TABLE (and RL_THETA for the initial state), steps every
/// variant to each table sample's time (never ahead of the data it has) and
/// publishes RL_MODEL_<name> stamped with that sample's utime.
///
/// Threading: single-threaded. Run() loops on lcm.handleTimeout; handlers
/// call HandleTable / HandleTheta, which the all-in-one run may call directly
/// (LCM then is only a tap). Shutdown: the stop flag ends the loop, then a
/// final RL_HEALTH "stopped" goes out.
///
/// Start and reset: at the first table sample with an RL_THETA not ahead of
/// it (the newest such among the last 1024 RL_THETA: the DAQ delays RL_TABLE
/// more than RL_THETA), the variants start at that RL_THETA's utime from its theta and
/// theta_dot (|theta| below rest_threshold_rad counts as at rest, so sensor
/// noise does not start a free rocking). Table samples before the start are
/// skipped and counted. A table utime that goes backwards (a replay
/// restarting, a new test) resets every variant, which start again the same
/// way from the new run's RL_THETA.

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "model/block.h"
#include "model/rocking_model.h"
#include "rocklab/block_state_t.hpp"
#include "rocklab/model_state_t.hpp"
#include "rocklab/table_state_t.hpp"

namespace rocklab::model {

/// One model variant to run: `NAME:MODEL:PARAMS` on the command line.
struct VariantSpec {
  std::string name;          ///< channel suffix: RL_MODEL_<name>; [A-Za-z0-9_]+
  ModelKind kind{};
  BlockParams params;
  std::string params_source; ///< "theoretical", "command line" or the JSON file
  ModelOptions options;
};

/// Parses `NAME:MODEL:PARAMS`, MODEL housner|complex, PARAMS `theoretical`
/// (then `theoretical` must hold the rig's geometric parameters),
/// `alpha=A,p=P,mu=M[,l=L][,handoff=K]` (rad, rad/s, 1, 1, 1; handoff: the
/// complex model's opt-in l -> 0 hand-off below K V_min, 0 = off, see
/// ModelOptions::complex_resolved_energy), or a JSON file with the keys
/// alpha, p, mu (and optionally l), as `rocklab fit --out` writes it.
/// @throws std::invalid_argument naming the variant and the part that is wrong.
VariantSpec ParseVariant(const std::string& text, const std::optional<BlockParams>& theoretical);

/// Reads alpha, p, mu (and l into `l` when present) from a JSON file.
/// @throws std::invalid_argument naming the file and key.
BlockParams ReadParamsJson(const std::string& path, double* l = nullptr);

struct ModelNodeConfig {
  std::string channel_prefix{"RL_"};
  std::vector<VariantSpec> variants;  ///< at least one
  double rest_threshold_rad{2e-3};    ///< |theta| at start below this: at rest, rad
  double health_period_s{1.0};        ///< RL_HEALTH period, host time, s
  /// Messages each LCM subscription of Run() may hold before LCM drops
  /// (silently). LCM's own default, 30, is 30 ms of a 1 kHz RL_TABLE: one
  /// scheduling hiccup of a loaded machine. 4096 is ~4 s at 1 kHz, a few
  /// hundred kB at most. >= 1.
  int subscriber_queue{4096};
  /// Optional observer, called synchronously with each RL_MODEL_<name>
  /// message right after it is published (also when there is no publisher),
  /// so a caller can feed the comparator by direct calls. Must not throw (an
  /// exception is caught, logged and counted as a failure).
  std::function<void(const rocklab::model_state_t&)> on_state;
  /// @throws std::invalid_argument naming the option.
  void Validate() const;
};

class ModelNode {
 public:
  /// @param publisher where RL_MODEL_*, RL_EVENT and RL_HEALTH go; not owned,
  ///        must outlive the node (null: nothing is published).
  /// @throws std::invalid_argument for an invalid configuration.
  ModelNode(const ModelNodeConfig& config, lcm::LCM* publisher);
  ~ModelNode();
  ModelNode(const ModelNode&) = delete;
  ModelNode& operator=(const ModelNode&) = delete;

  /// Direct-call entry points (also used by the LCM handlers). Never throw.
  void HandleTable(const rocklab::table_state_t& msg);
  void HandleTheta(const rocklab::block_state_t& msg);

  void Run(lcm::LCM& subscriber, const std::atomic<bool>& stop);
  /// Publishes the final RL_HEALTH.
  void Finish();

  /// The latest state of variant i (in configuration order).
  const rocklab::model_state_t& latest(std::size_t i) const;
  std::size_t variant_count() const;
  std::int64_t table_count() const { return table_count_; }
  std::int64_t skipped_before_start() const { return skipped_before_start_; }
  std::int64_t resets() const { return resets_; }
  std::int64_t failures() const { return failures_; }

 private:
  struct Variant;
  void Start(const rocklab::block_state_t& theta);
  void PublishHealth(const char* state);
  void OnTable(const lcm::ReceiveBuffer*, const std::string&, const rocklab::table_state_t* msg);
  void OnTheta(const lcm::ReceiveBuffer*, const std::string&, const rocklab::block_state_t* msg);

  ModelNodeConfig config_;
  lcm::LCM* publisher_;  // not owned
  std::vector<std::unique_ptr<Variant>> variants_;
  bool started_{};
  // The newest RL_THETA messages, a ring: the start state is the newest one
  // not ahead of the table sample, and RL_THETA runs ahead of RL_TABLE.
  static constexpr std::size_t kThetaHistory = 1024;  // > any differentiator delay difference
  std::vector<rocklab::block_state_t> theta_history_;
  std::size_t theta_count_{};  // pushed since the last time-going-back
  const rocklab::block_state_t& ThetaAt(std::size_t i) const;
  const rocklab::block_state_t* StartTheta(std::int64_t table_utime) const;
  std::int64_t last_table_utime_{INT64_MIN};
  std::int64_t start_utime_{};  // model time 0, us
  std::int64_t table_count_{}, skipped_before_start_{}, resets_{}, failures_{}, published_{};
  double last_health_host_s_{};
};

}  // namespace rocklab::model
