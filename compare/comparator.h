#pragma once
/// @file
/// Live error between the measured rocking angle and one model variant:
/// aligned pairs in, running metrics out. No allocation after construction.

#include <cstdint>
#include <vector>

#include "compare/crossings.h"

namespace rocklab::compare {

/// Knobs of a Comparator.
struct ComparatorOptions {
  double window_s{2.0};  ///< sliding RMS window, s; > 0
  /// Capacity of the sliding window, samples; must hold window_s at the
  /// acquisition rate (samples beyond it push the oldest out early).
  std::size_t max_window_samples{1 << 16};
  /// A zero crossing counts once |theta| has exceeded this on both sides, rad.
  double crossing_hysteresis_rad{2e-3};
  /// A model crossing this close to a measured one of the same direction is
  /// its match, s.
  double crossing_match_s{0.2};
  /// @throws std::invalid_argument naming the option.
  void Validate() const;
};

/// The metrics after the latest pair. Angles in rad, times in s. The four
/// crossing metrics (peak_error, impact_timing_error and their means) are
/// NaN while matched_crossings is 0: nothing was matched, so there is no
/// error to state (0 would read as a perfect match).
struct ComparisonMetrics {
  std::int64_t utime{};        ///< acquisition sample clock of the latest pair, us
  double error{};              ///< theta_model - theta_measured, rad
  double rms_window{};         ///< RMS of error over the valid pairs in the window, rad
  double rms_total{};          ///< RMS of error over all valid pairs, rad
  double nrms{};               ///< rms_total / peak |theta_measured|, 1 (0 before any rocking)
  double peak_measured{};      ///< peak |theta_measured| over the valid pairs, rad
  double peak_error{};         ///< latest matched half cycle: |peak model| - |peak measured|, rad
  double impact_timing_error{};///< latest matched zero crossing: t_model - t_measured, s
  double correlation{};        ///< Pearson correlation over the valid pairs, 1 (0 if undefined)
  bool valid{true};            ///< latest pair valid (DAQ saw no sliding, jump or twist)
  std::int64_t samples{};      ///< pairs seen
  std::int64_t valid_samples{};///< pairs that entered the metrics
  std::int64_t matched_crossings{};    ///< zero crossings matched between the two
  std::int64_t unmatched_crossings{};  ///< crossings of either side left without a match
  double max_abs_error{};      ///< largest |error| over the valid pairs, rad
  double mean_abs_timing_error{}; ///< mean |t_model - t_measured| of matched crossings, s
  double mean_abs_peak_error{};   ///< mean ||peak model| - |peak measured|| of matched half cycles, rad
};

/// Running comparison of one model variant with the measurement.
class Comparator {
 public:
  /// @throws std::invalid_argument for invalid options.
  explicit Comparator(const ComparatorOptions& options = {});

  /// One aligned pair at the same acquisition time (utime strictly
  /// increasing). An invalid pair (the 1-DOF model does not apply: the DAQ
  /// flags sliding, jump or twist) updates `error` and `valid` only.
  const ComparisonMetrics& Add(std::int64_t utime, double theta_measured, double theta_model,
                               bool valid);

  const ComparisonMetrics& metrics() const { return m_; }

 private:
  static constexpr int kCrossingRing = 16;
  struct CrossingRing {
    Crossing items[kCrossingRing];
    int next{};
    int size{};
    void Push(const Crossing& c);
  };

  void Match(CrossingRing& mine, CrossingRing& other, const Crossing& c, bool is_model);
  void ExpireCrossings(CrossingRing& ring, double now_s);

  ComparatorOptions options_;
  ComparisonMetrics m_;

  // Sliding window of squared errors (valid pairs only), as a ring.
  std::vector<double> window_time_s_;
  std::vector<double> window_sq_;
  std::size_t window_head_{};  // oldest
  std::size_t window_size_{};
  double window_sum_{};
  std::size_t window_pops_{};  // since the last exact recomputation

  // Totals over the valid pairs.
  double sum_sq_{};
  double mean_x_{}, mean_y_{}, m2_x_{}, m2_y_{}, c_xy_{};  // Welford co-moments
  double sum_abs_timing_{}, sum_abs_peak_{};

  CrossingTracker measured_tracker_, model_tracker_;
  CrossingRing measured_crossings_, model_crossings_;
};

}  // namespace rocklab::compare
