#pragma once
// The tests' reference integrator of Housner's equation: classical
// fixed-step RK4 with event bisection, written independently of rocklab's
// model code (which uses CVODE with root finding). Its derivation and
// measured error are in oracle_test.cpp (point 2 of its header;
// OracleTest.ReferenceIntegratorConvergesAtFourthOrder: ~1e-11 s and
// ~1e-12 rad at h = 1e-5 s). Used there against rocklab's models and by
// fit_synthetic.h to make the fit tests' records, so the fits are not
// checked against the forward model they use themselves.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <functional>
#include <utility>
#include <vector>

#include "model/block.h"

namespace rocklab::test::rk4 {

using model::BlockParams;
inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double kG = 9.81;  // m/s^2, the g of the model library (model/block.h)

struct RefOptions {
  double h_s{1e-5};             // RK4 step, s
  bool linearised{false};       // sin x -> x, cos x -> 1 (the closed forms' equation)
  double rest_interval_s{2e-3};  // impacts closer than this: rest
  double sample_rate_hz{100};   // theta sampled at k / rate (steps land on them)
  std::vector<double> breaks_s;  // discontinuities of the forcing (steps land on them), s
  // > 0: eq. (10)'s l -> 0 limit instead of Housner's model (docs/errata.md items
  // 3, 4): Housner's equation in r = alpha chi on the line psi_k of the
  // current excursion, the table's push projected on it (cos psi_k), theta =
  // r cos psi_k, and each crossing keeps mu^(1/w) of the speed and turns
  // the line by pi / w (Binet's exact crossing, u'' - (2 ln mu / pi) u' + u
  // = 0 for u = 1/chi), w = sqrt(1 - (ln mu / pi)^2). The value is w.
  double limit_w{0};
  // Only while the table cannot lift the block (|u_g''| <= g tan alpha)
  // does the 2 ms rule put it to rest (docs/errata.md item 6).
  bool rest_needs_quiet_table{true};
  // Impact n (0-based, counted from the start) keeps mu_per_impact[n] of
  // the speed instead of mu, where given (Housner's model only): a
  // restitution that scatters from impact to impact.
  std::vector<double> mu_per_impact;
  double theta0{0};      // initial state, rad and rad/s (both 0: at rest)
  double theta_dot0{0};
};

struct RefResult {
  std::vector<double> sample_theta;  // rad, at k / rate
  std::vector<double> impact_times;  // s
  std::vector<double> uplift_times;  // s
  std::vector<double> rest_times;    // s
  double peak{};                     // max |theta| over every step, rad
  double peak_time{};                // s
};

// Table acceleration u_g''(t), m/s^2; at a discontinuity, the limit from the
// left when `left` (an RK4 stage at a step's end), else from the right.
using Accel = std::function<double(double t, bool left)>;

class Reference {
 public:
  Reference(const BlockParams& b, Accel accel, RefOptions o) : b_(b), accel_(std::move(accel)), o_(o) {}

  RefResult Run(double duration_s) {
    RefResult r;
    const double thr = kG * std::tan(b_.alpha);
    double t = 0, th = o_.theta0, w = o_.theta_dot0, last_impact = -1e300;
    int side = th > 0 || (th == 0 && w > 0) ? +1 : (th < 0 || w < 0 ? -1 : 0);  // 0: at rest, else the corner (+1: +x)
    const double restitution = o_.limit_w > 0 ? std::pow(b_.mu, 1 / o_.limit_w) : b_.mu;
    double turn = 0;  // eq. (10)'s limit: the line's turn from the uplift's ray, rad
    proj_ = 1;
    std::size_t k = 0;
    const double dt_sample = 1.0 / o_.sample_rate_hz;
    auto next_sample = [&] { return static_cast<double>(k) * dt_sample; };
    const double t_end = duration_s * (1 + 1e-12);
    while (true) {
      while (k < static_cast<std::size_t>(1e9) && next_sample() <= t + 1e-12 && next_sample() <= t_end) {
        r.sample_theta.push_back(th * proj_);
        ++k;
      }
      if (next_sample() > t_end) break;
      double h = std::min(o_.h_s, next_sample() - t);
      for (double b : o_.breaks_s) {
        if (b > t + 1e-15 && b - t < h) h = b - t;
      }
      if (side == 0) {
        // At rest: the criterion where rest starts, then its first crossing.
        auto over = [&](double tt) { return std::abs(accel_(tt, false)) - thr; };
        if (over(t) > 0) {
          side = accel_(t, false) > 0 ? -1 : +1;
          r.uplift_times.push_back(t);
          continue;
        }
        if (over(t + h) <= 0) {
          t += h;
          continue;
        }
        double lo = t, hi = t + h;  // over(lo) <= 0 < over(hi)
        while (hi - lo > 1e-14) {
          const double mid = 0.5 * (lo + hi);
          (over(mid) > 0 ? hi : lo) = mid;
        }
        t = hi;  // the block is free where the criterion holds
        side = accel_(t, false) > 0 ? -1 : +1;
        r.uplift_times.push_back(t);
        continue;
      }
      double th1 = 0, w1 = 0;
      Rk4(t, th, w, side, h, th1, w1);
      if (side * th1 > 0) {
        t += h;
        th = th1;
        w = w1;
        if (std::abs(th * proj_) > r.peak) {
          r.peak = std::abs(th * proj_);
          r.peak_time = t;
        }
        if (std::abs(th) >= kPi / 2) break;  // overturned (not in these scenarios)
        continue;
      }
      // theta reached 0 within the step: bisect its length.
      double lo = 0, hi = h;
      while (hi - lo > 1e-14) {
        const double mid = 0.5 * (lo + hi);
        Rk4(t, th, w, side, mid, th1, w1);
        (side * th1 > 0 ? lo : hi) = mid;
      }
      Rk4(t, th, w, side, hi, th1, w1);
      t += hi;
      r.impact_times.push_back(t);
      const bool quiet = std::abs(accel_(t, false)) <= thr || !o_.rest_needs_quiet_table;
      if (t - last_impact < o_.rest_interval_s && quiet) {
        r.rest_times.push_back(t);
        side = 0;
        th = w = 0;
        last_impact = -1e300;
        turn = 0;
        proj_ = 1;
        continue;
      }
      last_impact = t;
      th = 0;
      const std::size_t n_impact = r.impact_times.size() - 1;
      w = (n_impact < o_.mu_per_impact.size() ? o_.mu_per_impact[n_impact] : restitution) * w1;
      side = -side;
      if (o_.limit_w > 0) {
        turn += kPi / o_.limit_w - kPi;  // beyond the half turn that switches the side
        proj_ = std::cos(turn);
      }
    }
    return r;
  }

 private:
  double Acc(double t, double th, int side, bool left = false) const {
    const double phi = b_.alpha * side - th;
    const double a = accel_(t, left) / kG * proj_;
    if (o_.linearised) return -b_.p * b_.p * (phi + a);
    return -b_.p * b_.p * (std::sin(phi) + a * std::cos(phi));
  }
  void Rk4(double t, double th, double w, int side, double h, double& th1, double& w1) const {
    const double k1x = w, k1v = Acc(t, th, side);
    const double k2x = w + 0.5 * h * k1v, k2v = Acc(t + 0.5 * h, th + 0.5 * h * k1x, side);
    const double k3x = w + 0.5 * h * k2v, k3v = Acc(t + 0.5 * h, th + 0.5 * h * k2x, side);
    const double k4x = w + h * k3v, k4v = Acc(t + h, th + h * k3x, side, true);
    th1 = th + h / 6 * (k1x + 2 * k2x + 2 * k3x + k4x);
    w1 = w + h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v);
  }

  BlockParams b_;
  Accel accel_;
  RefOptions o_;
  double proj_{1};  // eq. (10)'s limit: cos of the line's turn (theta = r cos, push projected)
};

}  // namespace rocklab::test::rk4
