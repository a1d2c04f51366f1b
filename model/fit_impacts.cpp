// The impacts method (the paper's): alpha and p from the half intervals
// between impacts against the quarter time T(r), mu from the peaks by
// eq. (14) (FitImpacts).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <numeric>
#include <optional>

#include "model/fit_impl.h"
#include "model/free_rocking.h"

namespace rocklab::model {
using namespace fit_detail;
namespace {

// One measured quarter time and the peak it belongs to.
struct TauPair {
  double r{};       // rad
  double tau{};     // s
  // tau = k0 t_c0 + k1 t_c1 (+ a release time): the impacts it is made of,
  // for the covariance of neighbouring half intervals, which share one.
  int c0{};
  int c1{};
  double k0{};
  double k1{};
  double release_var{};  // variance of the release time in tau, s^2
  double r_se{};         // standard error of r, rad
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

double MeanMu(double alpha, const std::optional<double>& r0, const std::vector<double>& peaks) {
  double sum = 0.0;
  int n = 0;
  for (std::size_t i = 0; i < peaks.size(); ++i) {
    const int k = static_cast<int>(i);
    if (r0 && *r0 < alpha) {
      sum += MuFromPeaks(alpha, *r0, peaks[i], k + 1);
      ++n;
    } else if (!r0 && i > 0) {
      sum += MuFromPeaks(alpha, peaks[0], peaks[i], k);
      ++n;
    }
  }
  return n > 0 ? sum / n : kNaN;
}

// dT/dr of each pair at x = (alpha, p), by central differences (the upper
// step kept below alpha).
std::vector<double> PairDtDr(const std::vector<TauPair>& pairs, QuarterTime kind, const Eigen::VectorXd& x) {
  std::vector<double> out;
  for (const TauPair& q : pairs) {
    const double h = 1e-6 * q.r;
    const double r_hi = std::min(q.r + h, 0.5 * (q.r + x(0)));
    out.push_back((QuarterTimeOf(kind, x(0), x(1), r_hi) - QuarterTimeOf(kind, x(0), x(1), q.r - h)) /
                  (r_hi - (q.r - h)));
  }
  return out;
}

// Standard error of the mean mu, linearised jointly over the record's
// independent noise sources: every impact time, the release time, r_0 and
// every peak. mu depends on alpha, r_0 and the peaks (eq. 14); alpha on the
// half intervals (impact and release times) and, through T(r), on the same
// peaks: d(alpha, p) = -(J^T J)^-1 J^T d(residuals), with d residual_i =
// dT/dr_i dr_i - d tau_i. So a peak moves mu directly and through alpha,
// and the two are added before squaring (treating them as independent, as
// before issue 32, under-covered: error / stated rms 1.26-1.38 over 160
// seeds). Variance times `scale`, as alpha's (SetCovariance). NaN where a perturbed
// peak leaves (0, alpha).
double MuStderr(const FreeRockingFeatures& f, const std::vector<TauPair>& pairs, bool release_pair,
                const LmOutcome& lm, QuarterTime kind, double scale) {
  try {
    const double alpha = lm.x(0);
    const auto m = static_cast<Eigen::Index>(pairs.size());
    Eigen::FullPivLU<Eigen::MatrixXd> lu(lm.jacobian.transpose() * lm.jacobian);
    if (!lu.isInvertible()) return kNaN;
    const Eigen::RowVectorXd a0 = (lu.inverse() * lm.jacobian.transpose()).row(0);  // d alpha / d residual, 1 x m
    const std::vector<double> dtdr = PairDtDr(pairs, kind, lm.x);
    const double ha = 1e-7;
    const double g_alpha = (MeanMu(alpha + ha, f.r0_rad, f.peak_rad) - MeanMu(alpha - ha, f.r0_rad, f.peak_rad)) / (2 * ha);
    double var = 0.0;
    // Impact times: tau_i = k0 t_c0 + k1 t_c1; d alpha = a0 . v (d residual = -d tau).
    for (std::size_t c = 0; c < f.impact_time_s.size(); ++c) {
      double d_alpha = 0.0;
      for (Eigen::Index i = 0; i < m; ++i) {
        const TauPair& q = pairs[static_cast<std::size_t>(i)];
        const double v = (q.c0 == static_cast<int>(c) ? q.k0 : 0.0) + (q.c1 == static_cast<int>(c) ? q.k1 : 0.0);
        d_alpha += a0(i) * v;
      }
      const double se = f.impact_time_stderr_s[c];
      var += std::pow(g_alpha * d_alpha * se, 2);
    }
    if (release_pair) var += std::pow(g_alpha * a0(0), 2) * pairs[0].release_var;  // tau_0 = t_1 - t_release
    const Eigen::Index offset = release_pair ? 1 : 0;
    if (f.r0_rad) {
      const double h = 1e-7 * *f.r0_rad;
      double d = (MeanMu(alpha, *f.r0_rad + h, f.peak_rad) - MeanMu(alpha, *f.r0_rad - h, f.peak_rad)) / (2 * h);
      if (release_pair) d += g_alpha * -a0(0) * dtdr[0];
      var += d * d * f.r0_stderr_rad * f.r0_stderr_rad;
    }
    std::vector<double> peaks = f.peak_rad;
    for (std::size_t i = 0; i < peaks.size(); ++i) {
      const double h = 1e-7 * f.peak_rad[i];
      peaks[i] = f.peak_rad[i] + h;
      const double up = MeanMu(alpha, f.r0_rad, peaks);
      peaks[i] = f.peak_rad[i] - h;
      const double down = MeanMu(alpha, f.r0_rad, peaks);
      peaks[i] = f.peak_rad[i];
      double d = (up - down) / (2 * h);
      const Eigen::Index pair = static_cast<Eigen::Index>(i) + offset;  // the pair of peak i
      if (pair < m) d += g_alpha * -a0(pair) * dtdr[static_cast<std::size_t>(pair)];
      var += d * d * f.peak_stderr_rad[i] * f.peak_stderr_rad[i];
    }
    return std::sqrt(scale * var);
  } catch (const std::invalid_argument&) {
    return kNaN;  // a perturbed peak left (0, alpha): no linearisation there
  }
}

// The impacts method's preconditions: free rocking with enough impacts.
void RequireFreeRockingImpacts(const RockingRecord& record, const FitOptions& options,
                               const FreeRockingFeatures& f) {
  if (record.has_table() && MaxAbsTable(record) > kForcedTableAccel) {
    throw FitError(record.source + ": not free rocking: the table acceleration reaches " +
                   Num(MaxAbsTable(record), 3) + " m/s^2 (a forced test); the impacts method needs "
                   "free rocking, use --method trajectory");
  }
  const int n_impacts = static_cast<int>(f.impact_time_s.size());
  if (n_impacts < options.min_impacts) {
    std::string times;
    for (double t : f.impact_time_s) times += (times.empty() ? "" : ", ") + Num(t, 5);
    throw FitError(record.source + ": only " + std::to_string(n_impacts) +
                   " usable impacts (at " + (times.empty() ? "none" : times + " s") +
                   "); the impacts method needs at least " + std::to_string(options.min_impacts) +
                   " impacts of free rocking with peaks above " + Num(f.min_peak_rad, 3) + " rad");
  }
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
// unweighted sum of squares would then be dominated by it. Sets
// `release_pair` when the first pair is the release pair.
std::vector<TauPair> MakeTauPairs(const FreeRockingFeatures& f, const FitOptions& options,
                                  bool& release_pair) {
  const int n_impacts = static_cast<int>(f.impact_time_s.size());
  std::vector<TauPair> pairs;
  release_pair = false;
  if (options.use_release && f.release_time_s && f.r0_rad &&
      f.release_time_stderr_s <= options.max_release_stderr_s) {
    pairs.push_back({*f.r0_rad, f.impact_time_s[0] - *f.release_time_s, 0, 0, 1.0, 0.0,
                     f.release_time_stderr_s * f.release_time_stderr_s, f.r0_stderr_rad});
    release_pair = true;
  }
  for (int i = 0; i + 1 < n_impacts; ++i) {
    pairs.push_back({f.peak_rad[i], (f.impact_time_s[i + 1] - f.impact_time_s[i]) / 2, i, i + 1, -0.5, 0.5,
                     0.0, f.peak_stderr_rad[i]});
  }
  return pairs;
}

// The fit's starts: the profile of the sum of squares over alpha on 81
// log-spaced points of (max r, pi/2), p in closed form for each (T = F(r;
// alpha) / p is linear in 1/p), which is a global search of the
// two-parameter problem; its local minima, best first, at most `count`.
std::vector<Eigen::VectorXd> StartingPoints(const std::vector<TauPair>& pairs, QuarterTime kind, double r_max,
                                            int count, const std::string& source) {
  const int n = 81;
  std::vector<double> alpha(n, kNaN), p(n, kNaN), rss(n, std::numeric_limits<double>::infinity());
  for (int i = 0; i < n; ++i) {
    const double x = std::pow(10.0, -5.0 + 5.0 * i / (n - 1.0));
    alpha[i] = r_max + (kPi / 2 - 1e-6 - r_max) * x;
    if (!(alpha[i] > r_max)) continue;
    double sff = 0.0;
    double sft = 0.0;
    double stt = 0.0;
    for (const TauPair& q : pairs) {
      const double fq = QuarterTimeOf(kind, alpha[i], 1.0, q.r);
      sff += fq * fq;
      sft += fq * q.tau;
      stt += q.tau * q.tau;
    }
    if (sft > 0) {
      rss[i] = stt - sft * sft / sff;
      p[i] = sff / sft;
    }
  }
  std::vector<std::pair<double, int>> minima;
  for (int i = 0; i < n; ++i) {
    const bool left = i == 0 || rss[i] <= rss[i - 1];
    const bool right = i == n - 1 || rss[i] <= rss[i + 1];
    if (left && right && std::isfinite(rss[i])) minima.emplace_back(rss[i], i);
  }
  if (minima.empty()) throw FitError(source + ": no starting point for the fit");
  std::sort(minima.begin(), minima.end());
  std::vector<Eigen::VectorXd> starts;
  for (std::size_t k = 0; k < minima.size() && static_cast<int>(k) < count; ++k) {
    Eigen::VectorXd x(2);
    x << alpha[minima[k].second], p[minima[k].second];
    starts.push_back(x);
  }
  return starts;
}

// r^T C^+ r with C = (I - H) S (I - H)^T, the covariance the noise S gives
// the unweighted fit's residuals r = (I - H) e (H = J (J^T J)^-1 J^T): with
// Gaussian noise chi-square with rank(C) = m - n degrees of freedom,
// whatever the correlation of neighbouring half intervals. NaN when S is
// not finite or J^T J is singular.
double WhitenedChi2(const LmOutcome& lm, const Eigen::MatrixXd& noise_cov) {
  const Eigen::MatrixXd& jac = lm.jacobian;
  const auto m = jac.rows();
  const auto n = jac.cols();
  Eigen::FullPivLU<Eigen::MatrixXd> lu(jac.transpose() * jac);
  if (!lu.isInvertible() || !noise_cov.allFinite() || m <= n) return kNaN;
  const Eigen::MatrixXd q = Eigen::MatrixXd::Identity(m, m) - jac * lu.inverse() * jac.transpose();
  const Eigen::MatrixXd c = q * noise_cov * q.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(0.5 * (c + c.transpose()));
  if (eig.info() != Eigen::Success) return kNaN;
  // Eigenvalues ascending: the first n are the null space of (I - H).
  const Eigen::VectorXd proj = eig.eigenvectors().transpose() * lm.residuals;
  double chi2 = 0.0;
  for (Eigen::Index i = n; i < m; ++i) {
    const double ev = eig.eigenvalues()(i);
    if (!(ev > 0.0)) return kNaN;
    chi2 += proj(i) * proj(i) / ev;
  }
  return chi2;
}

// What the noise alone gives the half intervals: their covariance S from
// the impact-time, release-time and peak standard errors (the peak through
// dT/dr at the solution `x` = (alpha, p)). Neighbouring half intervals share
// an impact, so S is tridiagonal: cov(tau_n, tau_n+1) = -0.25 se^2 of the
// shared impact (-0.5 se^2 next to the release pair).
Eigen::MatrixXd HalfIntervalNoise(const std::vector<TauPair>& pairs, const FreeRockingFeatures& f,
                                  QuarterTime kind, const Eigen::VectorXd& x) {
  const auto m = static_cast<Eigen::Index>(pairs.size());
  Eigen::MatrixXd noise_cov = Eigen::MatrixXd::Zero(m, m);
  const std::vector<double> dtdr_all = PairDtDr(pairs, kind, x);
  for (Eigen::Index i = 0; i < m; ++i) {
    const TauPair& q = pairs[static_cast<std::size_t>(i)];
    const double dtdr = dtdr_all[static_cast<std::size_t>(i)];
    for (Eigen::Index j = 0; j < m; ++j) {
      const TauPair& o = pairs[static_cast<std::size_t>(j)];
      double c = 0.0;
      for (int u = 0; u < 2; ++u) {
        for (int v = 0; v < 2; ++v) {
          const int cu = u == 0 ? q.c0 : q.c1;
          const int cv = v == 0 ? o.c0 : o.c1;
          const double ku = u == 0 ? q.k0 : q.k1;
          const double kv = v == 0 ? o.k0 : o.k1;
          if (cu == cv && ku != 0.0 && kv != 0.0) {
            const double se = f.impact_time_stderr_s[static_cast<std::size_t>(cu)];
            c += ku * kv * se * se;
          }
        }
      }
      noise_cov(i, j) = c;
    }
    noise_cov(i, i) += q.release_var + dtdr * dtdr * q.r_se * q.r_se;
  }
  return noise_cov;
}

// The fit is the paper's unweighted least squares; its covariance is the
// sandwich (J^T J)^-1 J^T S J (J^T J)^-1 with S the half intervals' noise,
// scaled up by the reduced chi-square only when the test rejects the
// residual as noise (scaling whenever chi2 / dof > 1 made the 68 % interval
// cover 75 % over 200 records: with ~18 dof chi2 / dof scatters by 33 %). Sets out.covariance and, unless withheld, the standard
// errors of alpha and p and their correlation.
void SetCovariance(const LmOutcome& lm, const Eigen::MatrixXd& noise_cov, FitResult& out) {
  const Eigen::MatrixXd& jac = lm.jacobian;
  Eigen::FullPivLU<Eigen::MatrixXd> lu(jac.transpose() * jac);
  if (lu.isInvertible() && noise_cov.allFinite()) {
    const Eigen::MatrixXd inv = lu.inverse();
    const double scale = out.p_value < out.significance ? out.chi2_per_dof : 1.0;
    out.covariance = scale * inv * jac.transpose() * noise_cov * jac * inv;
  } else {
    out.covariance = Covariance(lm);
  }
  out.mu_stderr = kNaN;
  if (!out.stderr_withheld) {
    out.alpha_stderr = std::sqrt(out.covariance(0, 0));
    out.p_stderr = std::sqrt(out.covariance(1, 1));
    out.alpha_p_correlation = out.covariance(0, 1) / (out.alpha_stderr * out.p_stderr);
  }
}

// One row per impact (and the release): tau_n, residual, noise, and mu_n by
// eq. (14) with the fitted alpha; without r_0 the first inter-impact peak is
// the reference and n counts from it. Returns the mu_n computed.
std::vector<double> AddImpactRows(const FreeRockingFeatures& f, const std::vector<TauPair>& pairs,
                                  bool release_pair, const LmOutcome& lm,
                                  const std::vector<double>& pair_sigma, FitResult& out) {
  const double alpha = out.params.alpha;
  const int n_impacts = static_cast<int>(f.impact_time_s.size());
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
      row.noise_s = pair_sigma[0];
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
      row.noise_s = pair_sigma[static_cast<std::size_t>(i + offset)];
      if (f.r0_rad && *f.r0_rad < alpha) {
        row.mu_n = MuFromPeaks(alpha, *f.r0_rad, rn, i + 1);
      } else if (!f.r0_rad && i > 0) {
        row.mu_n = MuFromPeaks(alpha, f.peak_rad[0], rn, i);
      }
      if (row.mu_n) mus.push_back(*row.mu_n);
    }
    out.impacts.push_back(row);
  }
  return mus;
}

}  // namespace

FitResult FitImpacts(const RockingRecord& record, const FitOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  FitResult out = StartFit(FitMethod::kImpacts, record, options);
  const FreeRockingFeatures& f = out.features;
  RequireFreeRockingImpacts(record, options, f);

  bool release_pair = false;
  const std::vector<TauPair> pairs = MakeTauPairs(f, options, release_pair);
  QuarterTimeFunctor functor(pairs, options.quarter_time);
  const double r_max = functor.r_max();
  const std::vector<Eigen::VectorXd> starts = StartingPoints(
      pairs, options.quarter_time, r_max, options.starts < 0 ? 3 : std::max(1, options.starts), record.source);
  LmOutcome lm;
  bool have = false;
  for (const Eigen::VectorXd& x : starts) {
    LmOutcome trial = RunLm(functor, x, 1e-12, 1e-12, 1e-12, 400, options, start);
    const bool better = !have || (LmConverged(trial.status) && !LmConverged(lm.status)) ||
                        (LmConverged(trial.status) == LmConverged(lm.status) &&
                         trial.residuals.squaredNorm() < lm.residuals.squaredNorm());
    if (better) lm = std::move(trial);
    have = true;
  }
  out.starts = static_cast<int>(starts.size());
  out.starts_refined = out.starts;
  if (lm.x(0) >= kPi / 2 - 1e-3) {
    throw FitError(record.source + ": not free rocking: no block explains the half intervals between "
                   "the impacts (the fitted alpha runs to pi/2, rms residual " +
                   Num(std::sqrt(lm.residuals.squaredNorm() / static_cast<double>(pairs.size())) * 1e3, 3) +
                   " ms); the impacts method needs free rocking, use --method trajectory for a forced test");
  }
  if (!LmConverged(lm.status) || !(lm.x(0) > r_max) || !(lm.x(1) > 0)) {
    throw FitError(record.source + ": the least-squares fit of (alpha, p) did not converge (status " +
                   std::to_string(static_cast<int>(lm.status)) + ")");
  }
  out.params.alpha = lm.x(0);
  out.params.p = lm.x(1);
  out.residuals = static_cast<int>(pairs.size());
  out.dof = out.residuals - 2;
  out.rms_residual = std::sqrt(lm.residuals.squaredNorm() / out.residuals);
  out.iterations = lm.iterations;
  out.evaluations = lm.evaluations;

  const Eigen::MatrixXd noise_cov = HalfIntervalNoise(pairs, f, options.quarter_time, lm.x);
  std::vector<double> pair_sigma(pairs.size());
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    pair_sigma[i] = std::sqrt(noise_cov(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(i)));
  }
  double noise_residual = kNaN;
  const double diagonal = DiagonalChi2(lm.residuals, pair_sigma, &noise_residual);
  SetNoiseVerdict(std::isfinite(diagonal) ? WhitenedChi2(lm, noise_cov) : kNaN, noise_residual,
                  LmConverged(lm.status), out);
  SetCovariance(lm, noise_cov, out);

  if (out.band && (out.params.alpha < out.band->lo || out.params.alpha > out.band->hi)) {
    throw FitError(record.source + ": fitted alpha " + Num(out.params.alpha, 4) +
                   " rad (p " + Num(out.params.p, 4) + " rad/s) is outside the admissible band [" +
                   Num(out.band->lo, 4) + ", " + Num(out.band->hi, 4) + "] rad (geometric alpha " +
                   Num(out.band->geometric, 4) + " rad, b +- " + Num(out.band->band_m, 3) +
                   " m): solution rejected (the paper's rule; widen with --alpha-band-m)");
  }

  const std::vector<double> mus = AddImpactRows(f, pairs, release_pair, lm, pair_sigma, out);
  if (mus.empty()) throw FitError(record.source + ": no mu_n could be computed");
  out.params.mu = std::accumulate(mus.begin(), mus.end(), 0.0) / static_cast<double>(mus.size());
  out.mu_spread = StdDev(mus);
  out.mu_stderr = MuStderr(f, pairs, release_pair, lm, options.quarter_time,
                           out.p_value < out.significance ? out.chi2_per_dof : 1.0);
  if (out.stderr_withheld) out.mu_stderr = kNaN;
  if (!f.r0_rad) {
    out.warnings.push_back("no peak before the first impact (no hold, no earlier peak): eq. (14) "
                           "uses the peak after impact 1 as r_0 and counts impacts from it");
  } else if (!release_pair && f.release_time_s) {
    out.warnings.push_back("release time known only to +-" + Num(f.release_time_stderr_s * 1e3, 2) +
                           " ms: the release-to-first-impact time is not used");
  } else if (!release_pair) {
    out.warnings.push_back("no hold before the release: the release-to-first-impact time is not used");
  }
  AddVerdictWarnings(out, "bridged");
  out.runtime_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace rocklab::model
