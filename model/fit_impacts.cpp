// The impacts method: alpha and p from the measured quarter times between
// impacts, mu from the peaks (FitImpacts).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <numeric>

#include "model/fit_impl.h"
#include "model/free_rocking.h"

namespace rocklab::model {
namespace {

using namespace fit_detail;  // the fit's private helpers (model/fit_impl.h)

// One measured quarter time and the peak it belongs to.
struct TauPair {
  double r{};    // rad
  double tau{};  // s
};

// Residuals T(r_i; alpha, p) - tau_i*. Outside alpha in (max r, pi/2) the
// quarter time does not exist: the residuals are those at the nearest
// admissible alpha plus a penalty that grows with the violation, so LM
// backs off.
struct QuarterTimeFunctor : Eigen::DenseFunctor<double> {
  QuarterTimeFunctor(std::vector<TauPair> pairs, QuarterTime kind)
      : Eigen::DenseFunctor<double>(2, static_cast<int>(pairs.size())),
        pairs_(std::move(pairs)),
        kind_(kind) {
    for (const TauPair& q : pairs_) r_max_ = std::max(r_max_, q.r);
  }
  int operator()(const Eigen::VectorXd& x, Eigen::VectorXd& f) const {
    ++*count_;
    const double lo = r_max_ * (1.0 + 1e-6);
    const double hi = kPi / 2 - 1e-6;
    const double alpha = std::clamp(x(0), lo, hi);
    const double p = std::max(x(1), 1e-6);
    const double penalty = 1e3 * (std::abs(alpha - x(0)) + std::abs(p - x(1)));
    for (std::size_t i = 0; i < pairs_.size(); ++i) {
      f(static_cast<Eigen::Index>(i)) = QuarterTimeOf(kind_, alpha, p, pairs_[i].r) - pairs_[i].tau + penalty;
    }
    return 0;
  }
  int evaluations() const { return *count_; }
  double r_max() const { return r_max_; }

  std::vector<TauPair> pairs_;
  QuarterTime kind_;
  double r_max_{0.0};
  std::shared_ptr<int> count_ = std::make_shared<int>(0);  // shared: NumericalDiff copies the functor
};

double StdDev(const std::vector<double>& v) {
  if (v.size() < 2) return kNaN;
  const double mean = std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
  double s = 0.0;
  for (double x : v) s += (x - mean) * (x - mean);
  return std::sqrt(s / static_cast<double>(v.size() - 1));
}

}  // namespace

FitResult FitImpacts(const RockingRecord& record, const FitOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  FitResult out = fit_detail::StartFit(FitMethod::kImpacts, record, options);
  const FreeRockingFeatures& f = out.features;

  const int n_impacts = static_cast<int>(f.impact_time_s.size());
  if (n_impacts < options.min_impacts) {
    std::string times;
    for (double t : f.impact_time_s) times += (times.empty() ? "" : ", ") + Num(t, 5);
    throw FitError(record.source + ": only " + std::to_string(n_impacts) +
                   " usable impacts (at " + (times.empty() ? "none" : times + " s") +
                   "); the impacts method needs at least " + std::to_string(options.min_impacts) +
                   " impacts of free rocking with peaks above " + Num(f.min_peak_rad, 3) + " rad");
  }
  if (record.has_table() && fit_detail::MaxAbsTable(record) > 0.05) {
    out.warnings.push_back("the table acceleration reaches " + Num(fit_detail::MaxAbsTable(record), 3) +
                           " m/s^2: the impacts method assumes free rocking");
  }

  // tau_n*: half the interval between impacts n and n+1, paired with the
  // peak r_n between them. Free rocking is symmetric about each peak, so the
  // half interval is exactly T(r_n), and it needs neither the peak time
  // (poorly defined where theta is flat) nor the release time. The release
  // pair (first impact minus release time, with r_0) is added only when a
  // hold makes the release identifiable to the precision of a crossing: it is
  // the largest amplitude and the one that best separates alpha from p, but
  // the onset of a fall from rest is quadratic in time, so noise blurs it
  // (0.02 deg at 500 Hz: about 2.5 ms against 0.3 ms for a crossing) and an
  // unweighted sum of squares would then be dominated by it.
  std::vector<TauPair> pairs;
  bool release_pair = false;
  if (options.use_release && f.release_time_s && f.r0_rad &&
      f.release_time_stderr_s <= options.max_release_stderr_s) {
    pairs.push_back({*f.r0_rad, f.impact_time_s[0] - *f.release_time_s});
    release_pair = true;
  }
  for (int i = 0; i + 1 < n_impacts; ++i) {
    pairs.push_back({f.peak_rad[i], (f.impact_time_s[i + 1] - f.impact_time_s[i]) / 2});
  }

  // Start: scan alpha over (max r, pi/2); for each alpha the best p is
  // closed form (T = F(r; alpha) / p is linear in 1/p).
  QuarterTimeFunctor functor(pairs, options.quarter_time);
  const double r_max = functor.r_max();
  double best_alpha = kNaN;
  double best_p = kNaN;
  double best_rss = std::numeric_limits<double>::infinity();
  for (int i = 0; i <= 80; ++i) {
    const double x = std::pow(10.0, -5.0 + 5.0 * i / 80.0);
    const double alpha = r_max + (kPi / 2 - 1e-6 - r_max) * x;
    if (!(alpha > r_max)) continue;
    double sff = 0.0;
    double sft = 0.0;
    double stt = 0.0;
    for (const TauPair& q : pairs) {
      const double fq = QuarterTimeOf(options.quarter_time, alpha, 1.0, q.r);
      sff += fq * fq;
      sft += fq * q.tau;
      stt += q.tau * q.tau;
    }
    const double rss = stt - sft * sft / sff;
    if (rss < best_rss && sft > 0) {
      best_rss = rss;
      best_alpha = alpha;
      best_p = sff / sft;
    }
  }
  if (!std::isfinite(best_alpha)) throw FitError(record.source + ": no starting point for the fit");

  Eigen::VectorXd x(2);
  x << best_alpha, best_p;
  const LmOutcome lm = RunLm(functor, x, 1e-12, 1e-12, 1e-12, 400, options, start);
  if (!LmConverged(lm.status) || !(lm.x(0) > r_max) || !(lm.x(1) > 0)) {
    throw FitError(record.source + ": the least-squares fit of (alpha, p) did not converge (status " +
                   std::to_string(static_cast<int>(lm.status)) + ")");
  }
  out.params.alpha = lm.x(0);
  out.params.p = lm.x(1);
  out.covariance = Covariance(lm);
  out.alpha_stderr = std::sqrt(out.covariance(0, 0));
  out.p_stderr = std::sqrt(out.covariance(1, 1));
  out.alpha_p_correlation = out.covariance(0, 1) / (out.alpha_stderr * out.p_stderr);
  out.mu_stderr = kNaN;
  out.residuals = static_cast<int>(pairs.size());
  out.dof = out.residuals - 2;
  out.rms_residual = std::sqrt(lm.residuals.squaredNorm() / out.residuals);
  out.iterations = lm.iterations;
  out.evaluations = lm.evaluations;

  if (out.band && (out.params.alpha < out.band->lo || out.params.alpha > out.band->hi)) {
    throw FitError(record.source + ": fitted alpha " + Num(out.params.alpha, 4) +
                   " rad (p " + Num(out.params.p, 4) + " rad/s) is outside the admissible band [" +
                   Num(out.band->lo, 4) + ", " + Num(out.band->hi, 4) + "] rad (geometric alpha " +
                   Num(out.band->geometric, 4) + " rad, b +- " + Num(out.band->band_m, 3) +
                   " m): solution rejected (the paper's rule; widen with --alpha-band-m)");
  }

  // mu_n by eq. (14) with the fitted alpha; without r_0 the first
  // inter-impact peak is the reference and n counts from it.
  const double alpha = out.params.alpha;
  std::vector<double> mus;
  const int offset = release_pair ? 1 : 0;
  if (f.r0_rad) {
    ImpactRow row;
    row.n = 0;
    row.time_s = f.release_time_s ? *f.release_time_s : kNaN;
    row.peak_rad = *f.r0_rad;
    if (release_pair) {
      row.tau_s = pairs[0].tau;
      row.residual_s = lm.residuals(0);
    }
    out.impacts.push_back(row);
  }
  for (int i = 0; i < n_impacts; ++i) {
    ImpactRow row;
    row.n = i + 1;
    row.time_s = f.impact_time_s[i];
    if (i + 1 < n_impacts) {
      const double rn = f.peak_rad[i];
      row.peak_rad = rn;
      row.tau_s = pairs[i + offset].tau;
      row.residual_s = lm.residuals(i + offset);
      if (f.r0_rad && *f.r0_rad < alpha) {
        row.mu_n = MuFromPeaks(alpha, *f.r0_rad, rn, i + 1);
      } else if (!f.r0_rad && i > 0) {
        row.mu_n = MuFromPeaks(alpha, f.peak_rad[0], rn, i);
      }
      if (row.mu_n) mus.push_back(*row.mu_n);
    }
    out.impacts.push_back(row);
  }
  if (mus.empty()) throw FitError(record.source + ": no mu_n could be computed");
  out.params.mu = std::accumulate(mus.begin(), mus.end(), 0.0) / static_cast<double>(mus.size());
  out.mu_spread = StdDev(mus);
  if (!f.r0_rad) {
    out.warnings.push_back("no peak before the first impact (no hold, no earlier peak): eq. (14) "
                           "uses the peak after impact 1 as r_0 and counts impacts from it");
  } else if (!release_pair && f.release_time_s) {
    out.warnings.push_back("release time known only to +-" + Num(f.release_time_stderr_s * 1e3, 2) +
                           " ms: the release-to-first-impact time is not used");
  } else if (!release_pair) {
    out.warnings.push_back("no hold before the release: the release-to-first-impact time is not used");
  }
  out.runtime_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace rocklab::model
