#include "compare/band_comparator.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include "common/units.h"

namespace rocklab::compare {
namespace {

using common::kNaN;
// Samples with member impacts kept (a ring): 8192 is ~250 measured
// crossings' worth of 32 members each.
constexpr std::size_t kImpactRing = 8192;
// How long a sample's impacts are kept, s: a measured crossing is found
// when the signal leaves the hysteresis band, which may be long after the
// sign change it dates from.
constexpr double kImpactRetention_s = 10.0;

double Fraction(std::int64_t in, std::size_t of) {
  return of > 0 ? static_cast<double>(in) / static_cast<double>(of) : kNaN;
}
double Fraction(std::int64_t in, std::int64_t of) {
  return of > 0 ? static_cast<double>(in) / static_cast<double>(of) : kNaN;
}

}  // namespace

BandComparator::BandComparator(const ComparatorOptions& options)
    : options_(options), window_(0), impacts_(kImpactRing) {
  options_.Validate();
  window_.resize(options_.max_window_samples);
  m_.coverage95_window = m_.coverage95_total = m_.coverage68_window = m_.coverage68_total = kNaN;
  m_.median_error = m_.width95 = kNaN;
  m_.impact_timing_z = m_.impact_time_sd = m_.impact_timing_z_rms = m_.impact_timing_z_max_abs = kNaN;
}

const BandMetrics& BandComparator::Add(std::int64_t utime, double theta_measured, bool valid,
                                       const BandSample& band) {
  if (!has_t0_) {
    has_t0_ = true;
    t0_utime_ = utime;
  }
  // Seconds after the first pair: full double resolution whatever the epoch.
  const double t_s = static_cast<double>(utime - t0_utime_) * 1e-6;
  m_.utime = utime;
  ++m_.samples;

  // The members' impacts are kept whether or not this pair is valid.
  for (int dir : {+1, -1}) {
    const int n = dir > 0 ? band.impacts_up : band.impacts_down;
    if (n <= 0) continue;
    if (impacts_size_ == impacts_.size()) {  // full: the oldest goes
      impacts_head_ = (impacts_head_ + 1) % impacts_.size();
      --impacts_size_;
    }
    Impacts& rec = impacts_[(impacts_head_ + impacts_size_) % impacts_.size()];
    rec = dir > 0 ? Impacts{t_s, dir, n, band.up_offset_sum, band.up_offset_sq_sum}
                  : Impacts{t_s, dir, n, band.down_offset_sum, band.down_offset_sq_sum};
    ++impacts_size_;
  }
  while (impacts_size_ > 0 && impacts_[impacts_head_].t_s < t_s - kImpactRetention_s) {
    impacts_head_ = (impacts_head_ + 1) % impacts_.size();
    --impacts_size_;
  }

  const bool finite = std::isfinite(theta_measured) && std::isfinite(band.lo95) &&
                      std::isfinite(band.hi95) && std::isfinite(band.lo68) && std::isfinite(band.hi68);
  m_.valid = valid && finite;
  if (!m_.valid) {
    tracker_.Break();
    ResolveDue(t_s, false);
    return m_;
  }
  ++m_.valid_samples;
  m_.median_error = band.median - theta_measured;
  m_.width95 = band.hi95 - band.lo95;
  const bool in95 = band.lo95 <= theta_measured && theta_measured <= band.hi95;
  const bool in68 = band.lo68 <= theta_measured && theta_measured <= band.hi68;

  // Sliding window (as Comparator's: a full ring pushes the oldest out early).
  const std::size_t cap = window_.size();
  while (size_ > 0 && (size_ == cap || window_[head_].t_s < t_s - options_.window_s)) {
    in95_window_ -= window_[head_].in95 ? 1 : 0;
    in68_window_ -= window_[head_].in68 ? 1 : 0;
    head_ = (head_ + 1) % cap;
    --size_;
  }
  window_[(head_ + size_) % cap] = Inside{t_s, in95, in68};
  ++size_;
  in95_window_ += in95 ? 1 : 0;
  in68_window_ += in68 ? 1 : 0;
  in95_total_ += in95 ? 1 : 0;
  in68_total_ += in68 ? 1 : 0;
  m_.coverage95_window = Fraction(in95_window_, size_);
  m_.coverage68_window = Fraction(in68_window_, size_);
  m_.coverage95_total = Fraction(in95_total_, m_.valid_samples);
  m_.coverage68_total = Fraction(in68_total_, m_.valid_samples);

  Crossing c;
  if (tracker_.Add(t_s, theta_measured, options_.crossing_hysteresis_rad, c)) {
    if (pending_size_ == kPending) {  // full: the oldest is resolved with what there is
      Resolve(pending_[0]);
      std::copy(pending_ + 1, pending_ + kPending, pending_);
      --pending_size_;
    }
    pending_[pending_size_++] = c;
  }
  ResolveDue(t_s, false);
  return m_;
}

const BandMetrics& BandComparator::Finish() {
  ResolveDue(0.0, true);
  return m_;
}

void BandComparator::ResolveDue(double now_s, bool all) {
  std::size_t done = 0;
  while (done < pending_size_ && (all || now_s >= pending_[done].time_s + options_.crossing_match_s)) {
    Resolve(pending_[done]);
    ++done;
  }
  if (done == 0) return;
  std::copy(pending_ + done, pending_ + pending_size_, pending_);
  pending_size_ -= done;
}

// The member impacts of the crossing's direction within crossing_match_s of
// it (by their samples' times), summed about the crossing's time t_m:
// sum (t - t_m) = n d + S1, sum (t - t_m)^2 = n d^2 + 2 d S1 + S2, with d the
// sample's time - t_m and S1, S2 its offset sums.
void BandComparator::Resolve(const Crossing& c) {
  double n = 0, s1 = 0, s2 = 0;
  for (std::size_t i = 0; i < impacts_size_; ++i) {
    const Impacts& r = impacts_[(impacts_head_ + i) % impacts_.size()];
    if (r.direction != c.direction) continue;
    const double d = r.t_s - c.time_s;
    if (std::abs(d) > options_.crossing_match_s) continue;
    n += r.count;
    s1 += r.count * d + r.sum;
    s2 += r.count * d * d + 2 * d * r.sum + r.sq_sum;
  }
  const double mean = n > 0 ? s1 / n : kNaN;
  const double var = n >= 2 ? std::max(0.0, (s2 - n * mean * mean) / (n - 1)) : 0.0;
  const double sd = std::sqrt(var);
  if (!(n >= 2) || !(sd > 0)) {
    ++m_.unmatched_crossings;
    return;
  }
  ++m_.matched_crossings;
  m_.impact_time_sd = sd;
  m_.impact_timing_z = mean / sd;
  z_sq_sum_ += m_.impact_timing_z * m_.impact_timing_z;
  m_.impact_timing_z_rms = std::sqrt(z_sq_sum_ / static_cast<double>(m_.matched_crossings));
  const double abs_z = std::abs(m_.impact_timing_z);
  m_.impact_timing_z_max_abs = std::isnan(m_.impact_timing_z_max_abs) ? abs_z : std::max(m_.impact_timing_z_max_abs, abs_z);
}

}  // namespace rocklab::compare
