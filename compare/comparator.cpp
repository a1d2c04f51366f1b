#include "compare/comparator.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace rocklab::compare {
namespace {

void Check(bool ok, const char* name) {
  if (!ok) throw std::invalid_argument(std::string("comparator option ") + name + " out of range");
}

}  // namespace

void ComparatorOptions::Validate() const {
  Check(std::isfinite(window_s) && window_s > 0, "window_s");
  Check(max_window_samples >= 2, "max_window_samples");
  Check(std::isfinite(crossing_hysteresis_rad) && crossing_hysteresis_rad >= 0,
        "crossing_hysteresis_rad");
  Check(std::isfinite(crossing_match_s) && crossing_match_s > 0, "crossing_match_s");
}

Comparator::Comparator(const ComparatorOptions& options) : options_(options) {
  options_.Validate();
  window_time_s_.resize(options_.max_window_samples);
  window_sq_.resize(options_.max_window_samples);
  // No crossing matched yet: no timing or peak error (not a perfect 0).
  constexpr double kNone = std::numeric_limits<double>::quiet_NaN();
  m_.peak_error = m_.impact_timing_error = kNone;
  m_.mean_abs_timing_error = m_.mean_abs_peak_error = kNone;
}

void Comparator::CrossingRing::Push(const Crossing& c) {
  items[next] = c;
  next = (next + 1) % kCrossingRing;
  size = std::min(size + 1, kCrossingRing);
}

void Comparator::Match(CrossingRing& mine, CrossingRing& other, const Crossing& c,
                       bool is_model) {
  Crossing* best = nullptr;
  for (int i = 0; i < other.size; ++i) {
    Crossing& o = other.items[i];
    if (o.matched || o.direction != c.direction) continue;
    if (std::abs(o.time_s - c.time_s) > options_.crossing_match_s) continue;
    if (!best || std::abs(o.time_s - c.time_s) < std::abs(best->time_s - c.time_s)) best = &o;
  }
  Crossing pushed = c;
  if (best) {
    best->matched = true;
    pushed.matched = true;
    const Crossing& model = is_model ? c : *best;
    const Crossing& measured = is_model ? *best : c;
    m_.impact_timing_error = model.time_s - measured.time_s;
    m_.peak_error = model.peak - measured.peak;
    ++m_.matched_crossings;
    sum_abs_timing_ += std::abs(m_.impact_timing_error);
    sum_abs_peak_ += std::abs(m_.peak_error);
    const double n = static_cast<double>(m_.matched_crossings);
    m_.mean_abs_timing_error = sum_abs_timing_ / n;
    m_.mean_abs_peak_error = sum_abs_peak_ / n;
  }
  // An unmatched crossing pushed out of a full ring is counted as lost.
  if (mine.size == kCrossingRing) {
    Crossing& oldest = mine.items[mine.next];
    if (!oldest.matched) {
      ++m_.unmatched_crossings;
      oldest.matched = true;
    }
  }
  mine.Push(pushed);
}

void Comparator::ExpireCrossings(CrossingRing& ring, double now_s) {
  // A crossing is detected up to a hysteresis delay after it happens, so the
  // other side's match can come until about 2 * crossing_match_s later.
  for (int i = 0; i < ring.size; ++i) {
    Crossing& c = ring.items[i];
    if (!c.matched && now_s - c.time_s > 2 * options_.crossing_match_s) {
      c.matched = true;
      ++m_.unmatched_crossings;
    }
  }
}

const ComparisonMetrics& Comparator::Add(std::int64_t utime, double theta_measured,
                                         double theta_model, bool valid) {
  m_.utime = utime;
  m_.error = theta_model - theta_measured;
  m_.valid = valid;
  ++m_.samples;
  if (!valid || !std::isfinite(m_.error)) {
    m_.valid = false;
    // The trackers do not interpolate across the invalid stretch.
    measured_tracker_.Break();
    model_tracker_.Break();
    return m_;
  }
  const double t_s = static_cast<double>(utime) * 1e-6;
  const double sq = m_.error * m_.error;
  ++m_.valid_samples;

  // Sliding window.
  const std::size_t cap = window_sq_.size();
  while (window_size_ > 0 &&
         (window_size_ == cap || window_time_s_[window_head_] < t_s - options_.window_s)) {
    window_sum_ -= window_sq_[window_head_];
    window_head_ = (window_head_ + 1) % cap;
    --window_size_;
    ++window_pops_;
  }
  const std::size_t tail = (window_head_ + window_size_) % cap;
  window_time_s_[tail] = t_s;
  window_sq_[tail] = sq;
  ++window_size_;
  window_sum_ += sq;
  if (window_pops_ >= cap) {  // bound the rounding drift of the running sum
    window_sum_ = 0;
    for (std::size_t i = 0; i < window_size_; ++i) window_sum_ += window_sq_[(window_head_ + i) % cap];
    window_pops_ = 0;
  }
  m_.rms_window = std::sqrt(std::max(0.0, window_sum_) / static_cast<double>(window_size_));

  // Totals.
  const double n = static_cast<double>(m_.valid_samples);
  sum_sq_ += sq;
  m_.rms_total = std::sqrt(sum_sq_ / n);
  m_.peak_measured = std::max(m_.peak_measured, std::abs(theta_measured));
  m_.nrms = m_.peak_measured > 0 ? m_.rms_total / m_.peak_measured : 0.0;
  m_.max_abs_error = std::max(m_.max_abs_error, std::abs(m_.error));
  const double dx = theta_measured - mean_x_;
  const double dy = theta_model - mean_y_;
  mean_x_ += dx / n;
  mean_y_ += dy / n;
  m2_x_ += dx * (theta_measured - mean_x_);
  m2_y_ += dy * (theta_model - mean_y_);
  c_xy_ += dx * (theta_model - mean_y_);
  m_.correlation = (m2_x_ > 0 && m2_y_ > 0) ? c_xy_ / std::sqrt(m2_x_ * m2_y_) : 0.0;

  // Zero crossings (impacts) and half-cycle peaks.
  Crossing c;
  const double h = options_.crossing_hysteresis_rad;
  if (measured_tracker_.Add(t_s, theta_measured, h, c)) {
    Match(measured_crossings_, model_crossings_, c, false);
  }
  if (model_tracker_.Add(t_s, theta_model, h, c)) {
    Match(model_crossings_, measured_crossings_, c, true);
  }
  ExpireCrossings(measured_crossings_, t_s);
  ExpireCrossings(model_crossings_, t_s);
  return m_;
}

}  // namespace rocklab::compare
