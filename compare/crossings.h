#pragma once
/// @file
/// Zero crossings of one sampled signal with hysteresis (the comparator's
/// impacts: theta crossing zero), shared by Comparator and BandComparator.

#include <algorithm>

namespace rocklab::compare {

/// A completed zero crossing.
struct Crossing {
  double time_s{};  ///< the latest sign change before it, linearly interpolated, s
  int direction{};  ///< +1: - to +, -1: + to -
  double peak{};    ///< |value| peak of the half cycle it ends
  bool matched{};   ///< the user's mark (matched, or given up)
};

/// A crossing counts once the signal has gone beyond +-hysteresis on both
/// sides; its time is the latest sign change before that.
class CrossingTracker {
 public:
  /// Adds the sample `v` at `t_s`; true and `out` filled when it completes a
  /// crossing.
  bool Add(double t_s, double v, double hysteresis, Crossing& out) {
    bool completed = false;
    if (has_last_ && ((last_v_ <= 0 && v > 0) || (last_v_ >= 0 && v < 0))) {
      cross_t_ = last_t_ + (0 - last_v_) * (t_s - last_t_) / (v - last_v_);
    }
    const int beyond = v > hysteresis ? 1 : (v < -hysteresis ? -1 : 0);
    if (beyond != 0 && beyond != side_) {
      if (side_ != 0) {
        out = Crossing{cross_t_, beyond, peak_, false};
        completed = true;
      }
      side_ = beyond;
      peak_ = 0;
    }
    if (side_ != 0) peak_ = std::max(peak_, side_ * v);
    last_t_ = t_s;
    last_v_ = v;
    has_last_ = true;
    return completed;
  }
  /// The next sample is not interpolated from the last (a gap, an invalid stretch).
  void Break() { has_last_ = false; }

 private:
  int side_{};                   // sign of the last excursion beyond the hysteresis
  double peak_{};                // |v| peak since then
  double last_t_{}, last_v_{};   // previous sample
  double cross_t_{};             // latest sign change, s
  bool has_last_{};
};

}  // namespace rocklab::compare
