#pragma once
/// @file
/// The measurement against an ensemble's posterior predictive band
/// (RL_BAND_<name>): how often theta_measured lies inside the 95 % and 68 %
/// bands (over the sliding window and since the start), and each measured
/// impact's time in units of the ensemble's impact-time spread. No
/// allocation after construction. Definitions in docs/models.md, "Posterior
/// predictive band".

#include <cstdint>
#include <vector>

#include "compare/comparator.h"
#include "compare/crossings.h"

namespace rocklab::compare {

/// One sample of the band (model_band_t's fields), rad and s.
struct BandSample {
  double lo95{}, lo68{}, median{}, hi68{}, hi95{};  ///< theta quantiles, rad
  /// The members' impacts in (previous sample, this one] by direction (up:
  /// theta from - to +): count, sum and sum of squares of t_impact - t_sample (s, s^2).
  int impacts_up{};
  double up_offset_sum{}, up_offset_sq_sum{};
  int impacts_down{};
  double down_offset_sum{}, down_offset_sq_sum{};
};

/// The band metrics after the latest pair. Fractions in 1, angles in rad,
/// times in s; NaN where there is nothing to state (no valid sample in the
/// window, no crossing resolved).
struct BandMetrics {
  std::int64_t utime{};           ///< acquisition sample clock of the latest pair, us
  double coverage95_window{};     ///< fraction of the window's valid samples inside [lo95, hi95], 1
  double coverage95_total{};      ///< the same over every valid sample, 1
  double coverage68_window{};     ///< inside [lo68, hi68], window, 1
  double coverage68_total{};      ///< since the start, 1
  double median_error{};          ///< median - theta_measured at the latest pair, rad
  double width95{};               ///< hi95 - lo95 at the latest pair, rad
  /// Latest resolved measured crossing: (mean of the ensemble's impact times
  /// near it - t_measured) / their sd, 1.
  double impact_timing_z{};
  double impact_time_sd{};        ///< that sd, s
  double impact_timing_z_rms{};   ///< RMS of impact_timing_z over the matched crossings, 1
  double impact_timing_z_max_abs{};  ///< largest |impact_timing_z|, 1
  std::int64_t matched_crossings{};  ///< measured crossings with a z
  /// Measured crossings without one: fewer than 2 member impacts of the same
  /// direction within crossing_match_s, or their sd 0.
  std::int64_t unmatched_crossings{};
  bool valid{true};               ///< latest pair valid
  std::int64_t samples{};         ///< pairs seen
  std::int64_t valid_samples{};   ///< pairs in the coverage
};

class BandComparator {
 public:
  /// window_s, crossing_hysteresis_rad and crossing_match_s as Comparator's.
  /// @throws std::invalid_argument for invalid options.
  explicit BandComparator(const ComparatorOptions& options = {});

  /// One aligned pair (utime strictly increasing). An invalid pair (DAQ
  /// flags, or a band or measurement that is not finite) updates `valid`,
  /// `samples` and the band's impacts only.
  const BandMetrics& Add(std::int64_t utime, double theta_measured, bool valid, const BandSample& band);
  /// Resolves the measured crossings still waiting for the ensemble's later
  /// impacts (the end of the record: those impacts will never come).
  const BandMetrics& Finish();

  const BandMetrics& metrics() const { return m_; }

 private:
  struct Impacts {  // one band sample's member impacts of one direction
    double t_s{};   // the sample's time, s after the first pair
    int direction{};
    int count{};
    double sum{}, sq_sum{};  // offsets from t_s: s, s^2
  };
  void Resolve(const Crossing& c);
  void ResolveDue(double now_s, bool all);

  ComparatorOptions options_;
  BandMetrics m_;
  std::int64_t t0_utime_{};
  bool has_t0_{};

  // Sliding window of the valid samples' (time, inside95, inside68), a ring.
  struct Inside {
    double t_s{};
    bool in95{}, in68{};
  };
  std::vector<Inside> window_;
  std::size_t head_{}, size_{};
  std::int64_t in95_window_{}, in68_window_{};
  std::int64_t in95_total_{}, in68_total_{};
  double z_sq_sum_{};

  CrossingTracker tracker_;
  // Measured crossings waiting for crossing_match_s of band after them.
  static constexpr std::size_t kPending = 16;
  Crossing pending_[kPending];
  std::size_t pending_size_{};
  // Samples with member impacts, oldest first (a ring): kept while a
  // crossing may still need them.
  std::vector<Impacts> impacts_;
  std::size_t impacts_head_{}, impacts_size_{};
};

}  // namespace rocklab::compare
