#pragma once
/// @file
/// The model node: runs one or more model variants beside the experiment.
/// It subscribes RL_TABLE (and RL_THETA for the initial state), steps every
/// variant to each table sample's time (never ahead of the data it has) and
/// publishes RL_MODEL_<name> (model_state3_t: the state and which equations
/// produced it) stamped with that sample's utime. A variant of an assembly
/// of two or more bodies (VariantSpec::stack) publishes model_state4_t on
/// its RL_MODEL_<name> instead: per-body arrays and the contact mode
/// (docs/channels.md); its events name the interface.
///
/// Threading: handlers run where the bus dispatches (the caller of Run on an
/// LcmBus; the publisher's thread on a DirectBus). With more than one variant
/// and ModelNodeConfig::threads > 1, each table sample's Step of the variants
/// is shared between that thread and threads-1 workers the node owns
/// (variant i on thread i % threads), and the handler waits for all of them
/// before it publishes: the messages go out from the handler's thread in
/// configuration order, exactly as single-threaded (each variant's stepping
/// depends on nothing but its own state and the sample). Workers wait for a
/// sample spinning briefly, then on a condition variable; the destructor
/// stops and joins them.
/// Shutdown order (Run): the stop flag ends the loop; what arrived before it
/// is dispatched (common::RunNodeLoop); Finish publishes RL_HEALTH "stopped";
/// the destructor unsubscribes.
///
/// Start, reset, gaps, bad samples and the lookahead are described in
/// docs/models.md ("The model node"): the variants start at the first table
/// sample from the newest RL_THETA (a stack variant from that sample's
/// RL_BODIES, block_state2_t, when there is one: its contact mode from the
/// bodies' relative angles; a state no mode admits is refused, counted and
/// said in an RL_EVENT, and the stack starts at rest), and a table utime
/// that goes back resets them all.
///
/// Ensembles (docs/models.md, "Posterior predictive band"): each is K
/// members (posterior draws) stepped with the variants, on the same threads
/// and the same samples; per table sample it publishes one RL_BAND_<name>
/// (model_band_t: theta's quantiles over the members and their impacts since
/// the previous sample) after the variants' messages, never a message per
/// member. A member whose integration fails leaves the band (counted,
/// logged once).

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "common/bus.h"
#include "common/ring.h"
#include "common/seq_gaps.h"
#include "model/block.h"
#include "model/ensemble.h"
#include "model/excitation.h"
#include "model/rocking_model.h"
#include "model/variant.h"
#include "rocklab/block_state2_t.hpp"
#include "rocklab/block_state_t.hpp"
#include "rocklab/model_band_t.hpp"
#include "rocklab/model_state3_t.hpp"
#include "rocklab/model_state4_t.hpp"
#include "rocklab/table_state_t.hpp"

namespace rocklab::model {

struct ModelNodeConfig {
  std::string channel_prefix{"RL_"};
  std::vector<VariantSpec> variants;  ///< at least one variant or ensemble
  /// Ensembles of posterior draws, each published as RL_BAND_<name>; their
  /// names must differ from each other (a variant may share one: the
  /// channels differ).
  std::vector<EnsembleSpec> ensembles;
  /// |theta| at start below this: at rest; for a stack, each interface's
  /// |relative angle| below this: closed, rad
  double rest_threshold_rad{2e-3};
  double health_period_s{1.0};        ///< RL_HEALTH period, host time, s
  /// Messages each subscription may hold before a queued bus (LcmBus) drops.
  /// LCM's own default, 30, is 30 ms of a 1 kHz RL_TABLE: one scheduling
  /// hiccup of a loaded machine. 4096 is ~4 s at 1 kHz, a few hundred kB at
  /// most. >= 1.
  int subscriber_queue{4096};
  /// Threads stepping the variants and ensemble members (the handler's
  /// included): 0 = one per model up to the hardware's cores, 1 = the handler's thread alone
  /// (the default: a variant's sample costs ~1 us with the Runge-Kutta
  /// stepping, less than handing it to another thread; docs/performance.md).
  /// >= 0.
  int threads{1};
  /// Table samples held before a sample is stepped (see above): 0 = step
  /// each sample as it arrives (live latency), N > 0 = N sample periods of
  /// latency for integration across samples. 0 .. 65536.
  int lookahead_samples{0};
  /// How every variant steps (ModelOptions::integrator, overriding the
  /// spec's). Runge-Kutta: the chord of the table samples kinks at every
  /// sample, where a one-step method loses nothing (docs/performance.md,
  /// "Work and precision": 1.04 steps per sample and 6e-12 rad against
  /// Adams' 8.1 and 1.5e-9 rad at rtol 1e-10, 7.5 times less CPU); the
  /// order-5 pair in fixed arrays, without ARKODE's bookkeeping per step
  /// ("Issue 33, third round").
  model::Integrator integrator{model::Integrator::kDormandPrince5};
  /// @throws std::invalid_argument naming the option.
  void Validate() const;
};

class ModelNode {
 public:
  /// Subscribes RL_TABLE and RL_THETA (and RL_BODIES when a variant is a
  /// stack) on `bus`, which RL_MODEL_*, RL_EVENT
  /// and RL_HEALTH go to. `bus` is not owned and must outlive the node.
  /// @throws std::invalid_argument for an invalid configuration.
  ModelNode(const ModelNodeConfig& config, common::Bus& bus);
  ~ModelNode();
  ModelNode(const ModelNode&) = delete;
  ModelNode& operator=(const ModelNode&) = delete;

  /// Loops on the bus until `stop` (health while idle), then Finish.
  void Run(const std::atomic<bool>& stop);
  /// Publishes the final RL_HEALTH.
  void Finish();

  /// What the RL_TABLE / RL_THETA / RL_BODIES handlers call. Never throw.
  void HandleTable(const rocklab::table_state_t& msg);
  void HandleTheta(const rocklab::block_state_t& msg);
  void HandleBodies(const rocklab::block_state2_t& msg);

  /// The latest state of variant i (in configuration order); its seq is
  /// the number the variant's next message will carry.
  const rocklab::model_state3_t& latest(std::size_t i) const;
  /// The latest message of variant i when it is a stack (nbodies 0 otherwise).
  const rocklab::model_state4_t& latest_bodies(std::size_t i) const;
  std::size_t variant_count() const;
  /// The latest band of ensemble i (in configuration order).
  const rocklab::model_band_t& band(std::size_t i) const;
  std::size_t ensemble_count() const { return ensembles_.size(); }
  /// Ensemble members whose integration failed (they left their band).
  std::int64_t member_failures() const { return member_failures_; }
  std::int64_t table_count() const { return table_count_; }
  std::int64_t skipped_before_start() const { return skipped_before_start_; }
  std::int64_t resets() const { return resets_; }
  std::int64_t failures() const { return failures_; }
  /// Stack variants' starts from RL_BODIES refused (the state admitted by
  /// no contact mode, another body count, another sample's): each started
  /// at rest and said in an RL_EVENT BAD_SAMPLE.
  std::int64_t start_refusals() const { return start_refusals_; }
  /// The stack variants' impacts resolved within the preloads, and with
  /// pivots held (stack::Stack::ImpactRule: the model's assumptions, named
  /// in their RL_EVENT's detail), over the node's life (resets included).
  std::int64_t impacts_preload() const { return impacts_preload_; }
  std::int64_t impacts_held_pivots() const { return impacts_held_pivots_; }
  /// Table samples whose acceleration was not finite (the last finite value was held).
  std::int64_t bad_table_samples() const { return bad_table_samples_; }
  /// RL_TABLE samples missing by their seq (forward jumps), in RL_HEALTH gaps.
  std::int64_t table_gaps() const { return table_seq_.missing(); }
  /// RL_THETA samples missing by their seq, also in RL_HEALTH gaps.
  std::int64_t theta_gaps() const { return theta_seq_.missing(); }
  /// RL_BODIES samples missing by their seq (subscribed with a stack variant), also in RL_HEALTH gaps.
  std::int64_t bodies_gaps() const { return bodies_seq_.missing(); }

 private:
  struct Runner;
  struct Variant;
  struct Ensemble;
  class Workers;
  // What a variant is stepped to: Step(t_s, accel) when horizon_s is NaN,
  // else AdvanceAhead(t_s, window_, horizon_s).
  struct Target {
    double t_s{};
    double accel{};
    std::int64_t utime{};
    double horizon_s{};
  };
  // Steps runner i (a variant's model or an ensemble member, on any
  // thread): its model and its failure.
  void StepRunner(std::size_t i, const Target& target);
  // An ensemble's band of the sample just stepped, published.
  void PublishBand(Ensemble& e, const Target& target);
  // A stack variant's stepper and constant message fields.
  void InitStackVariant(Variant& v, const ModelOptions& options);
  // A stack variant's model_state4_t and events of the sample just stepped.
  void PublishStack(Variant& v, const Target& target);
  // Steps every variant to `target` and publishes their messages and events.
  void StepAll(const Target& target);
  // Steps the oldest held sample (N > 0).
  void StepOldestHeld();
  // Steps every held sample with the window closed, then empties it.
  void FlushHeld();
  void Start(const rocklab::block_state_t& theta, std::int64_t start_utime);
  // A stack variant's start (at rest already): from the newest RL_BODIES
  // when it is that of `theta`, else refused or at rest.
  void StartStack(Variant& v, std::int64_t theta_utime);
  void PublishHealth(const char* state);
  void PublishEvent(std::int64_t utime, std::int8_t kind, double value, const std::string& detail);

  ModelNodeConfig config_;
  common::Bus& bus_;  // not owned
  std::vector<common::Subscription> subscriptions_;
  std::vector<std::unique_ptr<Variant>> variants_;
  std::vector<std::unique_ptr<Ensemble>> ensembles_;
  std::vector<Runner*> runners_;  // every model stepped: the variants', then the members
  std::unique_ptr<Workers> workers_;  // null when single-threaded
  std::string event_channel_, health_channel_;
  bool started_{};
  rocklab::block_state_t last_theta_{};  // the newest RL_THETA
  bool have_theta_{};
  // The newest RL_BODIES: what a stack's start reads, in fixed arrays (no
  // allocation per message). nbodies as received (may exceed kMaxBodies).
  struct Bodies {
    std::int64_t utime{};
    std::int32_t nbodies{};
    std::array<double, stack::kMaxBodies> theta{}, theta_dot{};  // rad, rad/s, clockwise positive
  };
  Bodies last_bodies_{};
  bool have_bodies_{};
  std::int64_t last_table_utime_{INT64_MIN};
  std::int64_t start_utime_{};  // model time 0, us
  double held_accel_mps2_{};    // the last finite table acceleration, m/s^2
  bool in_bad_stretch_{};
  std::int64_t bad_in_stretch_{};
  std::int64_t table_count_{}, skipped_before_start_{}, resets_{}, failures_{}, published_{};
  std::int64_t bad_table_samples_{};
  std::int64_t member_failures_{};
  std::int64_t start_refusals_{}, impacts_preload_{}, impacts_held_pivots_{};
  // Lookahead (N > 0): the window's samples and the utimes of those not yet
  // stepped (oldest first, at most N + 1).
  SampleWindow window_;
  common::Ring<std::int64_t> held_utime_;
  common::SeqGaps table_seq_;  // RL_TABLE seq (its missing: RL_HEALTH gaps)
  common::SeqGaps theta_seq_;  // RL_THETA seq (its missing: RL_HEALTH gaps)
  common::SeqGaps bodies_seq_;  // RL_BODIES seq (its missing: RL_HEALTH gaps)
  std::int64_t event_seq_{}, health_seq_{};  // seq of the next RL_EVENT, RL_HEALTH
  // RL_EVENT/RL_HEALTH sender: "model:<first variant>", unique on the bus
  // (several model processes may run; each RL_MODEL_<name> has one).
  std::string sender_;
  double last_health_host_s_{};
};

}  // namespace rocklab::model
