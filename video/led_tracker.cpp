#include "video/led_tracker.h"

#include <algorithm>

namespace rocklab::video {
namespace {

// A second blob in a gate farther than this many times the nearest does not
// make the LED ambiguous (the nearest is clearly it; the other is left over).
constexpr double kClearRatio = 3.0;
// Rates from two fits further apart than this are not trusted, s.
constexpr double kMaxRateGapS = 0.5;
// Blob statistics: samples before any is judged; the weight of a new sample
// afterwards (a memory of about 20 samples, so blur and distance changes
// over a swing are followed); a sample departs when it is off the mean by
// more than kDepartSigmas standard deviations and a fraction of the mean:
// kAreaFraction of its area (which fluctuates by a few pixels of ~20),
// kFluxFraction of its light (a sum over ~100 pixels, steady to ~1 %; a
// glint next to the LED raises the background of its box and takes light
// off before the blobs merge, then doubles it); after kReseedS of
// departures the statistics start again (the LED itself changed), counted.
constexpr int64_t kStatsWarmup = 10;
constexpr double kStatsWeight = 0.05;
constexpr double kDepartSigmas = 6.0;
constexpr double kAreaFraction = 0.35;
constexpr double kFluxFraction = 0.10;
constexpr double kReseedS = 1.0;
// An LED dropped from the rigid fit last frame is dropped again while its
// residual is at least this fraction of the worst one's.
constexpr double kHysteresis = 0.5;
// Rolling shutter: refits with the frame's own rates, at most, and the
// change of phi (rad) below which they stop.
constexpr int kRefits = 30;
constexpr double kRefitTolRad = 1e-10;

struct Fit {
  double phi, tx, tz, worst;
  int worst_at;
};

// Least-squares rigid 2-D fit world = R(phi) model + t over the LEDs in `used`.
Fit FitRigid(const std::vector<double>& mx, const std::vector<double>& mz, const std::vector<double>& wx,
             const std::vector<double>& wz, const std::vector<int>& used) {
  double cmx = 0, cmz = 0, cwx = 0, cwz = 0;
  for (int i : used) {
    cmx += mx[i];
    cmz += mz[i];
    cwx += wx[i];
    cwz += wz[i];
  }
  const double n = static_cast<double>(used.size());
  cmx /= n, cmz /= n, cwx /= n, cwz /= n;
  double dot = 0, cross = 0;
  for (int i : used) {
    const double ax = mx[i] - cmx, az = mz[i] - cmz, bx = wx[i] - cwx, bz = wz[i] - cwz;
    dot += ax * bx + az * bz;
    cross += ax * bz - az * bx;
  }
  Fit f{std::atan2(cross, dot), 0, 0, 0, -1};
  const double c = std::cos(f.phi), s = std::sin(f.phi);
  f.tx = cwx - (c * cmx - s * cmz);
  f.tz = cwz - (s * cmx + c * cmz);
  for (int i : used) {
    const double r = std::hypot(c * mx[i] - s * mz[i] + f.tx - wx[i], s * mx[i] + c * mz[i] + f.tz - wz[i]);
    if (r > f.worst) {
      f.worst = r;
      f.worst_at = i;
    }
  }
  return f;
}

}  // namespace

LedTracker::LedTracker(const VideoConfig& config, const PlaneMap& map)
    : map_(&map), leds_(config.leds), residual_m_(config.residual_m) {
  double spacing = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < leds_.size(); ++i) {
    for (std::size_t j = i + 1; j < leds_.size(); ++j) {
      spacing = std::min(spacing, std::hypot(leds_[i].x_m - leds_[j].x_m, leds_[i].z_m - leds_[j].z_m));
    }
  }
  gate_m_ = config.gate_m > 0 ? config.gate_m : (std::isfinite(spacing) ? 0.4 * spacing : 0.05);
  const std::size_t n = leds_.size();
  seen_.assign(n, false);
  pred_.resize(n);
  pick_.resize(n);
  jac_px_.reserve(4 * n);
  jac_xz_.reserve(4 * n);
  mx_.resize(n), mz_.resize(n), wx_.resize(n), wz_.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    mx_[i] = leds_[i].x_m;
    mz_[i] = leds_[i].z_m;
  }
  used_.reserve(n);
  blob_stats_.resize(n);
  rx_.resize(n), rz_.resize(n), led_dt_.assign(n, 0.0);
  dropped_last_.assign(n, false);
}

bool LedTracker::Departs(const BlobStats& st, const Blob& b) const {
  if (st.n < kStatsWarmup) return false;
  const auto off = [](double v, double mean, double var, double fraction) {
    return std::abs(v - mean) > std::max(kDepartSigmas * std::sqrt(var), fraction * mean);
  };
  return off(b.area_px, st.area_mean, st.area_var, kAreaFraction) ||
         (st.flux_mean > 0 && off(b.flux, st.flux_mean, st.flux_var, kFluxFraction));
}

void LedTracker::Learn(BlobStats& st, const Blob& b) {
  ++st.n;
  const auto update = [&st](double v, double& mean, double& var) {
    const double d = v - mean;
    if (st.n <= kStatsWarmup) {  // Welford: var holds the running sum of squares until the warm-up ends
      mean += d / static_cast<double>(st.n);
      var += d * (v - mean);
      if (st.n == kStatsWarmup) var /= static_cast<double>(st.n);
    } else {
      mean += kStatsWeight * d;
      var = (1 - kStatsWeight) * (var + kStatsWeight * d * d);
    }
  };
  update(b.area_px, st.area_mean, st.area_var);
  update(b.flux, st.flux_mean, st.flux_var);
  st.rejecting_since_s = std::numeric_limits<double>::quiet_NaN();
}

// Each used LED's position taken back from its row's time to row 0's along
// the rigid motion at `pose` with `rate`: d/dt (R(phi) m + t) =
// phi_dot R'(phi) m + t_dot.
void LedTracker::Correct(const double pose[3], const double rate[3]) {
  const double c = std::cos(pose[0]), s = std::sin(pose[0]);
  for (int i : used_) {
    const double vx = rate[0] * (-s * mx_[i] - c * mz_[i]) + rate[1];
    const double vz = rate[0] * (c * mx_[i] - s * mz_[i]) + rate[2];
    wx_[i] = rx_[i] - vx * led_dt_[i];
    wz_[i] = rz_[i] - vz * led_dt_[i];
  }
}

void LedTracker::Track(const std::vector<Blob>& blobs, double time_s, std::vector<LedSample>& out) {
  ++counts_.frames;
  const std::size_t n = leds_.size();
  out.assign(n, LedSample{});

  // Blobs on the plane.
  blob_px_.clear();
  for (const Blob& b : blobs) blob_px_.emplace_back(b.u_px, b.v_px);
  map_->ToPlane(blob_px_, blob_xz_);
  blob_users_.assign(blobs.size(), 0);

  // The LEDs where the block's motion puts them now (at rest before a fit).
  double pose[3] = {0, 0, 0};
  if (have_pose_) {
    const double dt = time_s - pose_time_s_;
    for (int k = 0; k < 3; ++k) pose[k] = pose_[k] + (have_rate_ ? rate_[k] * dt : 0.0);
  }
  const double c = std::cos(pose[0]), s = std::sin(pose[0]);
  for (std::size_t i = 0; i < n; ++i) {
    pred_[i] = {c * mx_[i] - s * mz_[i] + pose[1], s * mx_[i] + c * mz_[i] + pose[2]};
  }

  // Nearest blob in each gate; a comparable second one makes the LED ambiguous.
  for (std::size_t i = 0; i < n; ++i) {
    int best = -1, second = -1;
    double d1 = std::numeric_limits<double>::infinity(), d2 = d1;
    for (std::size_t j = 0; j < blobs.size(); ++j) {
      const double d = std::hypot(blob_xz_[j].x - pred_[i].x, blob_xz_[j].y - pred_[i].y);
      if (!(d < gate_m_)) continue;
      if (d < d1) {
        second = best, d2 = d1;
        best = static_cast<int>(j), d1 = d;
      } else if (d < d2) {
        second = static_cast<int>(j), d2 = d;
      }
    }
    pick_[i] = best;
    if (best < 0) {
      out[i].flags |= kLedMissing;
    } else if (blobs[static_cast<std::size_t>(best)].oversize) {
      out[i].flags |= kLedMerged;  // a blob too large for one LED
    } else if (second >= 0 && d2 < kClearRatio * d1) {
      out[i].flags |= kLedAmbiguous;
    }
    if (best >= 0) ++blob_users_[static_cast<std::size_t>(best)];
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (pick_[i] >= 0 && (out[i].flags & kLedAmbiguous) == 0) {
      // Claimed by another LED's gate as its nearest too: two LEDs in one blob.
      for (std::size_t k = 0; k < n; ++k) {
        if (k != i && pick_[k] == pick_[i]) out[i].flags |= kLedMerged;
      }
    }
  }

  // A blob off its LED's running statistics is not the LED alone.
  for (std::size_t i = 0; i < n; ++i) {
    BlobStats& st = blob_stats_[i];
    if (out[i].flags != 0 || !Departs(st, blobs[static_cast<std::size_t>(pick_[i])])) {
      st.rejecting_since_s = std::numeric_limits<double>::quiet_NaN();  // an episode of departures ends
      continue;
    }
    if (std::isnan(st.rejecting_since_s)) st.rejecting_since_s = time_s;
    if (time_s - st.rejecting_since_s > kReseedS) {
      st = BlobStats{};  // the LED changed for good: learn it again
      ++counts_.stat_restarts;
    } else {
      out[i].flags |= kLedOutlier;
    }
  }

  // The identified LEDs (taken back to row 0's time along the predicted
  // motion), then the rigid fit; the worst one off it is dropped until the
  // rest agree (two LEDs that disagree are both dropped).
  used_.clear();
  for (std::size_t i = 0; i < n; ++i) {
    if (out[i].flags != 0) continue;
    const cv::Point2d& p = blob_xz_[static_cast<std::size_t>(pick_[i])];
    wx_[i] = rx_[i] = p.x;
    wz_[i] = rz_[i] = p.y;
    led_dt_[i] = row_time_s_ * blobs[static_cast<std::size_t>(pick_[i])].v_px;
    used_.push_back(static_cast<int>(i));
  }
  const bool rolling = row_time_s_ > 0;
  if (rolling && have_rate_) Correct(pose, rate_);
  bool fitted = false;
  Fit fit{};
  // Hysteresis: an LED dropped last frame is dropped again while its
  // residual is at least kHysteresis of the worst one's, or of residual_m
  // when the rest would pass; so a systematic misfit (a lens that is not
  // calibrated: every LED a little off) does not make the dropped LEDs, and
  // theta with them, change from frame to frame with the noise.
  while (used_.size() >= 2) {
    fit = FitRigid(mx_, mz_, wx_, wz_, used_);
    int drop = fit.worst <= residual_m_ ? -1 : fit.worst_at;
    const double c_fit = std::cos(fit.phi), s_fit = std::sin(fit.phi);
    for (int i : used_) {
      if (!dropped_last_[static_cast<std::size_t>(i)] || (drop >= 0 && dropped_last_[static_cast<std::size_t>(drop)])) {
        continue;
      }
      const double r = std::hypot(c_fit * mx_[i] - s_fit * mz_[i] + fit.tx - wx_[i],
                                  s_fit * mx_[i] + c_fit * mz_[i] + fit.tz - wz_[i]);
      if (r >= kHysteresis * (drop >= 0 ? fit.worst : residual_m_)) drop = i;
    }
    if (drop < 0) {
      fitted = true;
      break;
    }
    if (drop != fit.worst_at || fit.worst <= residual_m_) ++counts_.held_drops;
    if (used_.size() == 2) {
      for (int i : used_) out[static_cast<std::size_t>(i)].flags |= kLedInconsistent;
      used_.clear();
      break;
    }
    out[static_cast<std::size_t>(drop)].flags |= kLedInconsistent;
    used_.erase(std::find(used_.begin(), used_.end(), drop));
  }
  for (std::size_t i = 0; i < n; ++i) dropped_last_[i] = (out[i].flags & kLedInconsistent) != 0;
  if (fitted && rolling && have_pose_) {
    // Again with the rates this frame's fit gives against the last one's
    // (a secant over the frame interval): the fit depends on those rates,
    // so this is iterated to its fixed point, which contracts by the LEDs'
    // mean delay over the frame interval (< 1 while the readout is shorter
    // than a frame). The rates' error then enters only through the
    // acceleration.
    const double dt = time_s - pose_time_s_;
    for (int iteration = 0; iteration < kRefits && dt > 0 && dt < kMaxRateGapS; ++iteration) {
      const double now[3] = {fit.phi, fit.tx, fit.tz};
      const double rate[3] = {(fit.phi - pose_[0]) / dt, (fit.tx - pose_[1]) / dt, (fit.tz - pose_[2]) / dt};
      Correct(now, rate);
      const double before = fit.phi;
      fit = FitRigid(mx_, mz_, wx_, wz_, used_);
      if (std::abs(fit.phi - before) < kRefitTolRad) break;
    }
  }

  // Samples, flags and counts.
  for (std::size_t i = 0; i < n; ++i) {
    LedSample& o = out[i];
    if (pick_[i] >= 0) {
      const Blob& b = blobs[static_cast<std::size_t>(pick_[i])];
      o.u_px = b.u_px;
      o.v_px = b.v_px;
      o.area_px = b.area_px;
      o.peak = b.peak;
      o.saturated_px = b.saturated_px;
    }
    if (o.flags == 0) {
      o.x_m = wx_[i];
      o.z_m = wz_[i];
      Learn(blob_stats_[i], blobs[static_cast<std::size_t>(pick_[i])]);
      if (o.saturated_px > 0) {
        o.flags |= kLedSaturated;
        ++counts_.saturated;
      }
    }
    if (o.flags & kLedMissing) {
      ++counts_.missing_samples;
      if (seen_[i]) ++counts_.occlusions;
    }
    counts_.merged += (o.flags & kLedMerged) ? 1 : 0;
    counts_.ambiguous += (o.flags & kLedAmbiguous) ? 1 : 0;
    counts_.inconsistent += (o.flags & kLedInconsistent) ? 1 : 0;
    counts_.outliers += (o.flags & kLedOutlier) ? 1 : 0;
    seen_[i] = (o.flags & kLedMissing) == 0;
  }
  for (std::size_t j = 0; j < blobs.size(); ++j) counts_.reflections += blob_users_[j] == 0 ? 1 : 0;

  // Centroid uncertainty on the plane: the pixel sigmas through the map's
  // Jacobian (central differences over 1 px; u and v errors independent,
  // the box being symmetric about the spot).
  jac_px_.clear();
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(out[i].x_m)) continue;
    const double u = out[i].u_px, v = out[i].v_px;
    jac_px_.insert(jac_px_.end(), {{u + 0.5, v}, {u - 0.5, v}, {u, v + 0.5}, {u, v - 0.5}});
  }
  if (!jac_px_.empty()) map_->ToPlane(jac_px_, jac_xz_);
  for (std::size_t i = 0, k = 0; i < n; ++i) {
    if (!std::isfinite(out[i].x_m)) continue;
    const Blob& b = blobs[static_cast<std::size_t>(pick_[i])];
    const cv::Point2d du = jac_xz_[k] - jac_xz_[k + 1], dv = jac_xz_[k + 2] - jac_xz_[k + 3];
    k += 4;
    out[i].sigma_x_m = std::hypot(du.x * b.sigma_u_px, dv.x * b.sigma_v_px);
    out[i].sigma_z_m = std::hypot(du.y * b.sigma_u_px, dv.y * b.sigma_v_px);
  }

  if (fitted) {
    ++counts_.fits;
    const double now[3] = {fit.phi, fit.tx, fit.tz};
    const double dt = time_s - pose_time_s_;
    have_rate_ = have_pose_ && dt > 0 && dt < kMaxRateGapS;
    for (int k = 0; k < 3; ++k) {
      rate_[k] = have_rate_ ? (now[k] - pose_[k]) / dt : 0.0;
      pose_[k] = now[k];
    }
    have_pose_ = true;
    pose_time_s_ = time_s;
  }
}

}  // namespace rocklab::video
