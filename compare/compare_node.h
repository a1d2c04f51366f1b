#pragma once
/// @file
/// The comparator node: subscribes RL_THETA and RL_MODEL_*, aligns each model
/// variant with the measurement by utime, publishes RL_COMPARE_<name> at a
/// configurable rate of the sample clock, reports stale inputs, and writes a
/// summary at the end.
///
/// Threading: single-threaded; handlers run where the bus dispatches. Run()
/// loops on the bus (common::RunNodeLoop) so that the stale checks and
/// health messages run when nothing arrives; on a DirectBus (`rocklab run`)
/// each RL_THETA also runs the stale checks. Shutdown order (Run): the stop
/// flag ends the loop; what arrived before it is compared; Finish publishes
/// a final RL_COMPARE per variant and a final RL_HEALTH; the destructor
/// unsubscribes.
///
/// Alignment: a model sample is paired with the measured sample of the same
/// utime. The rings below hold what one side has that the other has not yet
/// sent: over udpm the model process runs behind the DAQ by its queue.
///
/// Assemblies: a model_state4_t of nbodies >= 2 on RL_MODEL_<name> is
/// compared twice: its bottom body with RL_THETA as a single block's
/// (RL_COMPARE_<name>, comparison2_t, the summary row), and every body with
/// RL_BODIES (block_state2_t) by a BodiesComparator, the same alignment by
/// utime (RL_COMPAREBODIES_<name>, comparison3_t, the summary's "bodies").
///
/// Bands: RL_BAND_<name> (an ensemble's posterior predictive band,
/// model_band_t) is paired with the measurement the same way and compared
/// by a BandComparator; RL_COVERAGE_<name> (band_comparison_t) goes out at
/// the RL_COMPARE_* rate.

#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "common/bus.h"
#include "common/seq_gaps.h"
#include "common/ring.h"
#include "compare/band_comparator.h"
#include "compare/bodies_comparator.h"
#include "compare/comparator.h"
#include "rocklab/block_state2_t.hpp"
#include "rocklab/block_state_t.hpp"
#include "rocklab/model_band_t.hpp"
#include "rocklab/model_state3_t.hpp"
#include "rocklab/model_state4_t.hpp"

namespace rocklab::compare {

/// The clock staleness is measured on.
enum class StaleClock {
  /// Host time without input (live: a stopped DAQ or model process).
  kHost,
  /// Sample-clock time: an input is stale when the newest utime of any input
  /// is more than stale_after_s ahead of its own newest (offline runs, `run
  /// --max`, `compare --stale-clock sample` behind `replay --max`: a host
  /// stall never makes STALE/RECOVERED events).
  kSample,
};

struct CompareNodeConfig {
  std::string channel_prefix{"RL_"};
  double publish_rate_hz{20.0};    ///< RL_COMPARE_* rate in sample-clock time, Hz; > 0
  double stale_after_s{1.0};       ///< time without input before a stale event (stale_clock's), s; > 0
  StaleClock stale_clock{StaleClock::kHost};
  double health_period_s{1.0};     ///< RL_HEALTH period, host time, s; > 0
  std::size_t align_capacity{8192};///< samples buffered per side while waiting for a match
  /// Messages each subscription may hold before a queued bus (LcmBus) drops. LCM's own default, 30, is 15 ms of two 1 kHz models on the
  /// one RL_MODEL_* subscription. 8192 is ~4 s of two models at 1 kHz. >= 1.
  int subscriber_queue{8192};
  /// DAQ flags that make a pair invalid (1-DOF model not applicable):
  /// sliding | jump | twist by default.
  std::int32_t invalid_flags{rocklab::block_state_t::FLAG_SLIDING |
                             rocklab::block_state_t::FLAG_JUMP |
                             rocklab::block_state_t::FLAG_TWIST};
  ComparatorOptions comparator;
  /// An assembly's measured mode: |relative angle| at most this is a closed
  /// interface, rad (BodiesComparatorOptions::mode_rest_rad); >= 0.
  double mode_rest_rad{2e-3};
  /// @throws std::invalid_argument naming the option.
  void Validate() const;
};

/// The largest assembly the compare node pairs (bodies); a message of more
/// is counted as dropped.
inline constexpr int kMaxCompareBodies = 16;

/// End-of-run figures of one variant.
struct VariantSummary {
  std::string name;
  std::string model;
  double alpha{}, p{}, mu{};   ///< parameters the variant used: rad, rad/s, 1
  ComparisonMetrics metrics;   ///< at the end of the run
  std::int64_t unmatched_measured{};  ///< measured samples never paired
  std::int64_t unmatched_model{};     ///< model samples never paired
  /// An assembly variant (model_state4_t, nbodies >= 2) against RL_BODIES:
  /// the figures per body, bottom-up, and the mode agreement. Empty for a
  /// single block (its summary is unchanged).
  std::vector<ComparisonMetrics> bodies;
  ModeAgreement mode;
  std::int64_t bodies_unmatched_measured{};  ///< RL_BODIES samples never paired with it
  std::int64_t bodies_unmatched_model{};     ///< its samples never paired with RL_BODIES
};

/// End-of-run figures of one ensemble's band.
struct BandSummary {
  std::string name;
  std::string model;
  std::int32_t draws{};    ///< members the ensemble started with
  std::int32_t members{};  ///< members in its last band
  BandMetrics metrics;     ///< at the end of the run (pending crossings resolved)
  std::int64_t unmatched_measured{};  ///< measured samples never paired with a band sample
  std::int64_t unmatched_model{};     ///< band samples never paired
};

class CompareNode {
 public:
  /// Subscribes RL_THETA and RL_MODEL_* on `bus`, which RL_COMPARE_*,
  /// RL_EVENT and RL_HEALTH go to. `bus` is not owned and must outlive the node.
  /// @throws std::invalid_argument for an invalid configuration.
  CompareNode(const CompareNodeConfig& config, common::Bus& bus);
  ~CompareNode();
  CompareNode(const CompareNode&) = delete;
  CompareNode& operator=(const CompareNode&) = delete;

  /// What the handlers call.
  void HandleTheta(const rocklab::block_state_t& msg);
  /// RL_MODEL_* carries model_state3_t or (older logs) model_state2_t,
  /// model_state_t, read as model_state3_t with seq = common::kNoSeq.
  void HandleModel(const rocklab::model_state3_t& msg);
  /// RL_MODEL_* as the per-body type (what the node subscribes): body 0 to
  /// HandleModel; an assembly (nbodies >= 2) also to its BodiesComparator.
  void HandleModelBodies(const rocklab::model_state4_t& msg);
  /// RL_BODIES (block_state2_t): the measured bodies.
  void HandleBodies(const rocklab::block_state2_t& msg);
  /// RL_BAND_* (model_band_t).
  void HandleBand(const rocklab::model_band_t& msg);

  /// Loops on the bus until `stop` (stale checks and health while idle), then Finish.
  void Run(const std::atomic<bool>& stop);

  /// Stale checks on the configured clock (and the periodic RL_HEALTH).
  void CheckStale();
  /// Messages missing by their sequence numbers: RL_THETA (seq), RL_MODEL_*
  /// (seq; the sample clock for older types, which have none).
  std::int64_t theta_gaps() const { return theta_seq_.missing(); }
  std::int64_t model_gaps() const { return model_gaps_; }
  /// Publishes the final RL_COMPARE of every variant and RL_HEALTH "stopped".
  void Finish();

  std::vector<VariantSummary> Summary() const;
  /// The bands' figures (after Finish: every measured crossing resolved).
  std::vector<BandSummary> BandSummaries() const;
  /// The summary as a table (stdout) and as JSON (file); throws naming the
  /// file when it cannot be written. The JSON's "bands" holds `bands`
  /// (docs/commands.md, `run --summary`).
  static void PrintSummary(const std::vector<VariantSummary>& summary, std::FILE* out);
  static void PrintBandSummary(const std::vector<BandSummary>& bands, std::FILE* out);
  static void WriteSummaryJson(const std::vector<VariantSummary>& summary,
                               const std::string& path);
  static void WriteSummaryJson(const std::vector<VariantSummary>& summary,
                               const std::vector<BandSummary>& bands, const std::string& path);
  /// The document WriteSummaryJson writes (`run --json` prints it).
  static std::string SummaryJsonText(const std::vector<VariantSummary>& summary,
                                     const std::vector<BandSummary>& bands);

  std::int64_t theta_count() const { return theta_count_; }
  std::int64_t model_count() const { return model_count_; }

 private:
  struct Variant;
  struct Band;
  struct BodiesVariant;
  struct BodiesMeasured;
  struct BodiesModelSample;
  BodiesVariant& BodiesVariantFor(const rocklab::model_state4_t& msg);
  void PairBodies(BodiesVariant& v, const BodiesMeasured& measured, const BodiesModelSample& modelled);
  void PublishBodies(BodiesVariant& v);
  Variant& VariantFor(const rocklab::model_state3_t& msg);
  Band& BandFor(const rocklab::model_band_t& msg);
  // Whether a stream last published at `last_pub_utime` publishes at `utime`
  // (publish_rate_hz of the sample clock; the first pair always).
  bool PublishDue(std::int64_t utime, std::int64_t last_pub_utime) const;
  // Index of the measured sample of `utime` in measured_, or its size when none.
  std::size_t FindMeasured(std::int64_t utime) const;
  // Counts a forward jump of a model-side channel's seq into model_gaps_.
  void CountSeq(common::SeqGaps& gaps, std::int64_t seq);
  void Pair(Variant& v, std::int64_t utime, double measured, bool valid, double modelled);
  void PairBand(Band& b, std::int64_t utime, double measured, bool valid, const BandSample& band);
  void PublishCompare(Variant& v);
  void PublishCoverage(Band& b);
  void PublishEvent(std::int8_t kind, const std::string& source, double value,
                    const std::string& detail);
  void PublishHealth(const char* state);

  CompareNodeConfig config_;
  common::Bus& bus_;  // not owned
  std::vector<common::Subscription> subscriptions_;
  std::map<std::string, std::unique_ptr<Variant>> variants_;
  std::vector<Variant*> order_;  // variants in order of appearance
  std::map<std::string, std::unique_ptr<Band>> bands_;
  std::vector<Band*> band_order_;  // bands in order of appearance
  std::map<std::string, std::unique_ptr<BodiesVariant>> bodies_variants_;
  std::vector<BodiesVariant*> bodies_order_;
  // RL_BODIES samples waiting for the assembly variants (made at the first).
  std::unique_ptr<common::Ring<BodiesMeasured>> bodies_measured_;
  rocklab::model_state3_t body0_;  // HandleModelBodies' body 0, reused
  std::int64_t bodies_count_{};        // RL_BODIES messages taken
  std::int64_t bodies_dropped_{};      // RL_BODIES or RL_MODEL_* refused: nbodies out of range, out of order
  common::SeqGaps bodies_seq_;         // RL_BODIES seq

  // Measured samples waiting for the models, oldest first, utime increasing.
  struct Measured {
    std::int64_t utime{};
    double theta{};
    bool valid{};
  };
  common::Ring<Measured> measured_;

  std::int64_t theta_count_{}, model_count_{}, published_{};
  std::int64_t theta_out_of_order_{};  // RL_THETA not newer than the last: dropped, counted
  // Sequence gaps (RL_HEALTH gaps): RL_THETA by its seq; RL_MODEL_* by its
  // seq, or (older types, no seq) on the sample clock, a utime step over 1.5
  // sample periods (the period: the smallest RL_THETA utime step seen).
  common::SeqGaps theta_seq_;  // RL_THETA seq (its missing: RL_HEALTH gaps)
  std::int64_t model_gaps_{};  // RL_MODEL_* messages missing (seq, or the sample clock)
  std::int64_t event_seq_{}, health_seq_{};  // seq of the next RL_EVENT, RL_HEALTH
  std::int64_t last_theta_utime_{INT64_MIN};
  std::int64_t period_us_{};  // 0 until two RL_THETA are seen
  double last_theta_host_s_{};
  bool theta_stale_{};
  double last_health_host_s_{};
  std::int64_t newest_utime_{};
};

}  // namespace rocklab::compare
