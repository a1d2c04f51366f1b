// The posterior of a record's block parameters: priors, the impacts and
// trajectory likelihoods, the sampler run and its summary
// (model/posterior.h; docs/identification.md).
#include "model/posterior.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <thread>

#include <nlohmann/json.hpp>

#include "model/excitation.h"
#include "model/fit_impl.h"
#include "model/free_rocking.h"
#include "common/units.h"

namespace rocklab::model {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
using common::kNaN;

// The record's table acceleration, delayed by `offset_s` against theta:
// u_g''(t - offset).
class ShiftedForcing final : public Forcing {
 public:
  ShiftedForcing(const SampledAcceleration& inner, double offset_s) : inner_(inner), offset_(offset_s) {}
  double TableAcceleration(double t_s) const override { return inner_.TableAcceleration(t_s - offset_); }
  double NextDiscontinuity(double t_s) const override { return inner_.NextDiscontinuity(t_s - offset_) + offset_; }

 private:
  const SampledAcceleration& inner_;
  double offset_;
};

// A point of the model's theta(t): theta and theta_dot on either side (they
// differ at an impact).
struct Knot {
  double t, theta, left, right;
};

// Sum of (model theta - th[i])^2 over the samples i in [k, t.size()): the
// model is advanced to every `stride`-th sample only, and theta between
// comes from cubic Hermite interpolation of (theta, theta_dot) between its
// outputs, split at its events (an impact, uplift or rest: theta = 0 there,
// theta_dot jumps). Between knots theta is smooth, so the interpolation
// error is h^4/384 max|d4 theta/dt4| (h the knots' spacing): ~1e-9 rad at
// h = 10 ms for block 1 (docs/identification.md). +infinity when the model
// overturns. `token` (may be null) is polled every kPosteriorPollSamples
// samples: a run over a long record takes seconds.
constexpr std::size_t kPosteriorPollSamples = 256;
double ResidualSquares(RockingModel& m, const Forcing& forcing, const std::vector<double>& t,
                       const std::vector<double>& th, std::size_t k, int stride, const CancelToken* token) {
  const ModelState& s = m.state();
  std::size_t unpolled = 0;  // samples since the token was last polled
  Knot a{s.time_s, s.theta, s.theta_dot, s.theta_dot};
  std::size_t seen = m.events().size();
  double ss = 0.0;
  std::vector<Knot> knots;
  while (k < t.size()) {
    const std::size_t last = std::min(k + static_cast<std::size_t>(stride), t.size()) - 1;
    unpolled += last + 1 - k;
    if (token != nullptr && unpolled >= kPosteriorPollSamples) {
      unpolled = 0;
      token->ThrowIfCancelled();
    }
    m.AdvanceAhead(t[last], forcing, kInf);
    knots.assign(1, a);
    for (; seen < m.events().size(); ++seen) {
      const ModelEvent& e = m.events()[seen];
      if (e.kind == EventKind::kOverturn) return kInf;
      const bool impact = e.kind == EventKind::kImpact;
      const double before = impact ? e.value : 0.0;
      const double after = !impact ? 0.0 : std::isfinite(e.value_after) ? e.value_after : before;
      knots.push_back({e.time_s, 0.0, before, after});
    }
    a = {s.time_s, s.theta, s.theta_dot, s.theta_dot};
    knots.push_back(a);
    std::size_t j = 0;
    for (; k < last; ++k) {
      while (j + 2 < knots.size() && t[k] > knots[j + 1].t) ++j;
      const Knot& p = knots[j];
      const Knot& q = knots[j + 1];
      const double h = q.t - p.t;
      double v = q.theta;
      if (h > 0.0) {
        const double u = std::clamp((t[k] - p.t) / h, 0.0, 1.0);
        const double u2 = u * u, u3 = u2 * u;
        v = (2 * u3 - 3 * u2 + 1) * p.theta + (u3 - 2 * u2 + u) * h * p.right + (-2 * u3 + 3 * u2) * q.theta +
            (u3 - u2) * h * q.left;
      }
      ss += (v - th[k]) * (v - th[k]);
    }
    ss += (s.theta - th[last]) * (s.theta - th[last]);
    k = last + 1;
  }
  return ss;
}

double MaxAbs(const std::vector<double>& v) {
  double m = 0.0;
  for (double x : v) m = std::max(m, std::abs(x));
  return m;
}

}  // namespace

void PosteriorPriors::Validate() const {
  auto bad = [](const std::string& what) { throw std::invalid_argument(what); };
  if (!(alpha_band_m > 0.0)) bad("posterior.alpha_band_m must be > 0 m, got " + fit_detail::Num(alpha_band_m, 4));
  if (!(p_range > 0.0 && p_range < 1.0)) bad("posterior.p_range must be in (0, 1), got " + fit_detail::Num(p_range, 4));
  if (!(mu_min >= 0.0 && mu_min < mu_max && mu_max <= 1.0)) {
    bad("posterior.mu_min and mu_max must satisfy 0 <= mu_min < mu_max <= 1, got " + fit_detail::Num(mu_min, 4) + " and " +
        fit_detail::Num(mu_max, 4));
  }
  if (!(log10_l_min < log10_l_max && log10_l_min >= -20.0 && log10_l_max <= -2.0)) {
    bad("posterior.log10_l_min and log10_l_max must satisfy -20 <= min < max <= -2, got " + fit_detail::Num(log10_l_min, 4) +
        " and " + fit_detail::Num(log10_l_max, 4));
  }
  if (!(t_offset_s > 0.0 && t_offset_s <= 1.0)) bad("posterior.t_offset_s must be in (0, 1] s, got " + fit_detail::Num(t_offset_s, 4));
  if (!(sigma_mu_max > 0.0 && sigma_mu_max <= 0.5)) {
    bad("posterior.sigma_mu_max must be in (0, 0.5], got " + fit_detail::Num(sigma_mu_max, 4));
  }
}

void PosteriorOptions::Validate() const {
  fit.Validate();
  priors.Validate();
  if (!fit.geometry) {
    throw std::invalid_argument("the posterior needs the block geometry (--rig or --width/--height): its priors "
                                "come from it");
  }
  if (!(rtol > 0.0 && rtol < 1e-3)) throw std::invalid_argument("posterior rtol must be in (0, 1e-3), got " + fit_detail::Num(rtol, 4));
  if (priors.per_impact_mu && method != FitMethod::kImpacts) {
    throw std::invalid_argument("per-impact restitution (posterior.per_impact_mu) is implemented for the impacts "
                                "likelihood only (--method impacts)");
  }
  if (start_scan < 0) throw std::invalid_argument("start scan must be >= 0 points, got " + std::to_string(start_scan));
  if (output_stride < 1 || output_stride > 1000) {
    throw std::invalid_argument("output stride must be in [1, 1000] samples, got " + std::to_string(output_stride));
  }
  if (burn_in >= sampler.steps - 3) {
    throw std::invalid_argument("burn-in " + std::to_string(burn_in) + " leaves fewer than 4 of " +
                                std::to_string(sampler.steps) + " steps");
  }
}

// ---- the problem -------------------------------------------------------------

struct PosteriorProblem::Impl {
  RockingRecord record;
  PosteriorOptions options;
  FreeRockingFeatures f;
  AlphaBand band;
  BlockParams theory;
  bool forced{};
  bool complex{};
  std::vector<std::string> names;
  Eigen::VectorXd lo, hi;
  int i_sigma{}, i_offset{};
  int i_sigma_mu{-1};  // per-impact restitution's sigma_mu (-1: one mu)
  double noise{};
  // Impacts: the release is known (the first pair starts from it).
  bool release{};
  // Trajectory: free from a held release, the first sample, the held level.
  bool from_hold{};
  std::size_t first{};
  double theta0{};
  std::unique_ptr<SampledAcceleration> table;
  FitResult point;
  bool point_fitted{};
  std::string point_error;
  // Where the walkers start: the best of the point fit and a scan of the
  // prior (Search).
  Eigen::VectorXd start;
  bool start_from_scan{};

  double LogPrior(const Eigen::VectorXd& x) const {
    for (Eigen::Index i = 0; i < x.size(); ++i) {
      if (!(x(i) > lo(i) && x(i) <= hi(i))) return -kInf;
    }
    return -std::log(x(i_sigma));  // sigma log-uniform; the others uniform
  }

  BlockParams Params(const Eigen::VectorXd& x) const { return {x(0), x(1), x(2)}; }

  double ImpactsLogLikelihood(const Eigen::VectorXd& x) const {
    const double alpha = x(0), p = x(1), mu = x(2);
    const double k = x(i_sigma) / noise;  // every feature's error is linear in the noise
    const double off = x(i_offset);
    const std::size_t n = f.impact_time_s.size();
    // The chain starts from r_0 before the first impact, or (a record that
    // starts at a peak, without r_0) from the peak after the first impact.
    const std::size_t i0 = f.r0_rad ? 0 : 1;
    double r = f.r0_rad ? *f.r0_rad : f.peak_rad[0];
    if (!(r < alpha)) return -kInf;
    double t = release ? *f.release_time_s + off + QuarterTimeExact(alpha, p, r) : f.impact_time_s[i0] + off;
    double chi2 = 0.0, log_det = 0.0;
    // Per-impact restitution: the whitened residuals z and their
    // derivatives h by each impact's mu_j - mu (j = i0.., the impacts whose
    // next peak is measured), docs/identification.md; dt_dmu accumulates
    // the next impact time's derivatives.
    const bool scatter = i_sigma_mu >= 0;
    const Eigen::Index m = scatter ? static_cast<Eigen::Index>(n - 1 - i0) : 0;
    thread_local Eigen::VectorXd z, dt_dmu;
    thread_local Eigen::MatrixXd h;
    if (scatter) {
      z.resize(2 * m + 1);
      h.setZero(2 * m + 1, m);
      dt_dmu.setZero(m);
    }
    Eigen::Index row = 0;
    for (std::size_t i = i0; i < n; ++i) {
      const double st = k * f.impact_time_stderr_s[i];
      const double zt = (f.impact_time_s[i] - t) / st;
      chi2 += zt * zt;
      log_det += std::log(st);
      if (scatter) {
        z(row) = zt;
        h.row(row++) = dt_dmu.transpose() / st;
      }
      if (i + 1 == n) break;
      r = NextPeak(alpha, mu, r);
      const double sr = k * f.peak_stderr_rad[i];
      const double zr = (f.peak_rad[i] - r) / sr;
      chi2 += zr * zr;
      log_det += std::log(sr);
      const double q = QuarterTimeExact(alpha, p, r);
      t += 2.0 * q;
      if (scatter) {
        // e = cos(alpha - r) - cos alpha is mu_j^2 times the previous one at
        // every impact j, so d r / d mu_j = (2 / mu) e / sin(alpha - r) for
        // every impact j up to this one; the next impact time moves by
        // 2 T'(r) times that (a forward difference: relative error ~1e-7
        // from the step and from T's 1e-14 accuracy).
        const double dr = 2.0 / mu * (std::cos(alpha - r) - std::cos(alpha)) / std::sin(alpha - r);
        const double step = 1e-7 * std::min(r, alpha - r);
        const double dq = (QuarterTimeExact(alpha, p, r + step) - q) / step;
        const Eigen::Index j_last = static_cast<Eigen::Index>(i - i0);
        z(row) = zr;
        h.row(row).head(j_last + 1).setConstant(dr / sr);
        ++row;
        dt_dmu.head(j_last + 1).array() += 2.0 * dq * dr;
      }
    }
    if (scatter && m > 0) {
      // Marginal of the mu_j ~ N(mu, sigma_mu^2), linear in them: the
      // whitened covariance I + s2 H H^T, by Woodbury and the determinant
      // lemma through the m x m matrix A = I + s2 H^T H.
      const double s2 = x(i_sigma_mu) * x(i_sigma_mu);
      Eigen::MatrixXd a = s2 * h.transpose() * h;
      a.diagonal().array() += 1.0;
      const Eigen::LLT<Eigen::MatrixXd> llt(a);
      if (llt.info() != Eigen::Success) return -kInf;
      const Eigen::VectorXd b = h.transpose() * z;
      chi2 -= s2 * b.dot(llt.solve(b));
      log_det += llt.matrixLLT().diagonal().array().log().sum();  // 0.5 log det A
    }
    return -0.5 * chi2 - log_det;
  }

  // Free rocking of Housner's model (no table): SampleFreeHousner at every
  // sample from the release (a record without one stays at rest: theta 0).
  double FreeHousnerLogLikelihood(const Eigen::VectorXd& x, const CancelToken* token) const {
    if (token != nullptr) token->ThrowIfCancelled();  // a run is ~50 ns per sample
    const std::vector<double>& t = record.time_s;
    const std::vector<double>& th = record.theta;
    const double sigma = x(i_sigma);
    double ss = 0.0;
    std::size_t k = first;
    double t0 = t[first], r0 = 0.0;
    if (from_hold) {
      t0 = *f.release_time_s + x(i_offset);
      r0 = theta0;
      for (; k < t.size() && t[k] <= t0; ++k) ss += (theta0 - th[k]) * (theta0 - th[k]);
    }
    thread_local std::vector<double> model_theta;
    model_theta.resize(t.size() - k);
    const FreeHousnerRun run = SampleFreeHousner(Params(x), t0, r0, 0.0, t.data() + k, t.size() - k,
                                                 model_theta.data(), ModelOptions{}.rest_impact_interval_s);
    if (run.overturned) return -kInf;
    for (std::size_t i = 0; i < model_theta.size(); ++i) {
      const double d = model_theta[i] - th[k + i];
      ss += d * d;
    }
    const double m = static_cast<double>(t.size() - first);
    return -0.5 * ss / (sigma * sigma) - m * std::log(sigma);
  }

  // The latest time >= t0_s up to which a block at rest from t0_s stays at
  // rest under the table delayed by offset_s: the start of the table's
  // interval (its samples shifted by offset_s) in which u_g'' first leaves
  // the uplift band [-g tan alpha_+, g tan alpha_-], as the table is read
  // between its samples (LeavesBand). t0_s itself when u_g''(t0_s) is
  // outside.
  double RestUntil(const BlockParams& params, double offset_s, double t0_s) const {
    const double up = kGravity * std::tan(params.Side(-1).alpha);   // u_g'' above: onto -x
    const double down = -kGravity * std::tan(params.Side(+1).alpha);
    auto outside = [&](double a) { return a > up || a < down; };
    double from = t0_s - offset_s;  // table time
    if (outside(table->TableAcceleration(from))) return t0_s;
    double rest_s = t0_s;
    const std::vector<double>& tt = record.table_time_s;
    for (auto j = static_cast<std::size_t>(std::upper_bound(tt.begin(), tt.end(), from) - tt.begin());
         j < tt.size(); ++j) {
      // Before the first sample the table is still (0); from it, one piece.
      const bool leaves = j == 0 ? outside(record.table_accel_mps2[0]) : LeavesBand(from, tt[j], down, up);
      if (leaves) return rest_s;
      rest_s = tt[j] + offset_s;
      from = tt[j];
    }
    return rest_s;
  }

  // Whether the table as read leaves [down, up] on [a_s, b_s], a part of one
  // interval between its samples (table time). Each reading is a cubic at
  // most there (the chord, the spline, Catmull-Rom's), so its extremes are
  // at the ends or where its derivative, a quadratic through the Newton
  // differences of four equally spaced values, vanishes; each is evaluated
  // exactly. The chord's interior extremes are none.
  bool LeavesBand(double a_s, double b_s, double down, double up) const {
    auto at = [&](double u) { return table->TableAcceleration(a_s + (b_s - a_s) * u / 3.0); };
    auto outside = [&](double a) { return a > up || a < down; };
    const double f0 = at(0.0), f1 = at(1.0), f2 = at(2.0), f3 = at(3.0);
    if (outside(f0) || outside(f3)) return true;
    if (table->interpolation() == Interpolation::kLinear) return false;
    const double d1 = f1 - f0, d2 = f2 - 2.0 * f1 + f0, d3 = f3 - 3.0 * f2 + 3.0 * f1 - f0;
    // f'(u) = A u^2 + B u + C on u in [0, 3].
    const double qa = 0.5 * d3, qb = d2 - d3, qc = d1 - 0.5 * d2 + d3 / 3.0;
    double roots[2];
    int n = 0;
    if (std::abs(qa) <= 1e-14 * (std::abs(qb) + std::abs(qc))) {
      if (qb != 0.0) roots[n++] = -qc / qb;
    } else {
      const double disc = qb * qb - 4.0 * qa * qc;
      if (disc >= 0.0) {
        const double q = -0.5 * (qb + std::copysign(std::sqrt(disc), qb));
        if (q != 0.0) roots[n++] = q / qa;
        roots[n++] = q != 0.0 ? qc / q : -qb / (2.0 * qa);
      }
    }
    for (int i = 0; i < n; ++i) {
      if (roots[i] > 0.0 && roots[i] < 3.0 && outside(at(roots[i]))) return true;
    }
    return false;
  }

  // The free Housner run costs ~50 ns per sample (0.5 ms for 10 s at 1 kHz,
  // 5 ms for 100 000 samples): a check before each run stops it soon enough.
  double TrajectoryLogLikelihood(const Eigen::VectorXd& x, const CancelToken* token) const {
    if (!complex && !table && options.free_rk4) return FreeHousnerLogLikelihood(x, token);
    ModelOptions mo;
    mo.rtol = options.rtol;
    mo.atol = 1e-10;
    mo.integrator = options.integrator;
    if (complex) mo.l = std::pow(10.0, x(3));
    auto model = RockingModel::Create(complex ? ModelKind::kComplex : ModelKind::kHousner, Params(x), mo);
    const std::vector<double>& t = record.time_s;
    const std::vector<double>& th = record.theta;
    const double sigma = x(i_sigma);
    const double off = x(i_offset);
    double ss = 0.0;
    std::size_t k = first;
    const NoTableMotion none;
    std::unique_ptr<ShiftedForcing> shifted;
    if (table) shifted = std::make_unique<ShiftedForcing>(*table, off);
    const Forcing& forcing = shifted ? static_cast<const Forcing&>(*shifted) : none;
    if (from_hold) {
      const double tr = *f.release_time_s + off;
      for (; k < t.size() && t[k] <= tr; ++k) ss += (theta0 - th[k]) * (theta0 - th[k]);
      model->Reset(tr, theta0, 0.0);
    } else {
      // At rest (theta = 0) until the table first leaves the uplift band:
      // the model starts there, without CVODE's rest steps (a third of a
      // forced run's steps on figure 7's record; docs/performance.md).
      const double rest_s = table ? RestUntil(Params(x), off, t[first]) : t[first];
      for (; k < t.size() && t[k] < rest_s; ++k) ss += th[k] * th[k];
      model->Reset(rest_s, 0.0, 0.0);
    }
    // The complex model is output at every sample: its slow crossings are
    // integrated through (no jump to split at), and every 10th sample moved
    // the log posterior by tens at the bench's start in a trial (docs/performance.md,
    // "The forced complex likelihood").
    ss += ResidualSquares(*model, forcing, t, th, k, complex ? 1 : options.output_stride, token);
    const double m = static_cast<double>(t.size() - first);
    return -0.5 * ss / (sigma * sigma) - m * std::log(sigma);
  }

  // `token` (may be null): polled inside the trajectory likelihood's model
  // run (the impacts likelihood is closed-form: microseconds).
  double LogPosterior(const Eigen::VectorXd& x, const CancelToken* token) const {
    const double prior = LogPrior(x);
    if (!std::isfinite(prior)) return -kInf;
    try {
      const double ll =
          options.method == FitMethod::kImpacts ? ImpactsLogLikelihood(x) : TrajectoryLogLikelihood(x, token);
      return std::isfinite(ll) ? prior + ll : -kInf;
    } catch (const Cancelled&) {
      throw;
    } catch (const std::exception&) {
      return -kInf;  // a model that cannot run there (e.g. a peak beyond alpha)
    }
  }
};

namespace {

// The walkers' start: the point fit (or the geometry) against start_scan points
// drawn uniformly from the prior of alpha, p, mu (and log10 l), sigma at the
// estimated noise and no offset; the highest log posterior wins. It catches
// a point fit that failed or stopped far from the mode when the prior holds
// a better point at random; on a forced test in a chaotic regime the mode's
// basin is far narrower than the scan's spacing (docs/identification.md),
// and the start is the point fit's.
void SearchStart(PosteriorProblem::Impl& s, const CancelToken& token) {
  const int scan = s.options.start_scan;
  const int dim = static_cast<int>(s.names.size());
  const BlockParams b = s.point_fitted ? s.point.params : s.theory;
  Eigen::VectorXd x0(dim);
  x0(0) = b.alpha;
  x0(1) = b.p;
  x0(2) = b.mu;
  if (s.complex) x0(3) = std::log10(kDefaultL);
  x0(s.i_sigma) = s.noise;
  x0(s.i_offset) = 0.0;
  // sigma_mu from the point fit's scatter of the mu_n from peak pairs
  // (which holds the peaks' noise too: an upper estimate).
  if (s.i_sigma_mu >= 0) {
    const double spread = s.point_fitted ? s.point.mu_spread : kNaN;
    x0(s.i_sigma_mu) = std::isfinite(spread) ? spread : 0.1 * s.hi(s.i_sigma_mu);
  }
  if (s.point_fitted && s.options.method == FitMethod::kTrajectory && s.point.release_time_s && s.f.release_time_s) {
    x0(s.i_offset) = *s.point.release_time_s - *s.f.release_time_s;
  }
  // Inside the support, a hundredth of its width from an end.
  for (Eigen::Index i = 0; i < dim; ++i) {
    const double margin = 0.01 * (s.hi(i) - s.lo(i));
    x0(i) = std::clamp(x0(i), s.lo(i) + margin, s.hi(i) - margin);
  }
  // Evaluates the points in parallel (each thread its share, this one's
  // too), returns the best index.
  const int threads = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  auto best_of = [&](const std::vector<Eigen::VectorXd>& pts, double& best_lp) {
    std::vector<double> lp(pts.size());
    common::RunOnThreads(threads, token, [&](int t) {
      for (std::size_t k = static_cast<std::size_t>(t); k < pts.size(); k += static_cast<std::size_t>(threads)) {
        lp[k] = s.LogPosterior(pts[k], &token);
      }
    });
    std::size_t best = 0;
    for (std::size_t k = 1; k < pts.size(); ++k) {
      if (lp[k] > lp[best]) best = k;
    }
    best_lp = lp[best];
    return best;
  };
  std::vector<Eigen::VectorXd> trial(scan + 1, x0);
  RandomStream rng(0x5CA9, 0);
  const int sampled = s.complex ? 4 : 3;
  for (int k = 1; k <= scan; ++k) {
    for (int i = 0; i < sampled; ++i) trial[static_cast<std::size_t>(k)](i) = s.lo(i) + (s.hi(i) - s.lo(i)) * rng.Uniform();
  }
  double lp_start = -kInf;
  const std::size_t first = best_of(trial, lp_start);
  s.start = trial[first];
  s.start_from_scan = first != 0;
}

}  // namespace

PosteriorProblem::PosteriorProblem(const RockingRecord& record, const PosteriorOptions& options,
                                   const FitResult* point) {
  options.Validate();
  auto impl = std::make_shared<Impl>();
  Impl& s = *impl;
  s.record = record;
  s.options = options;
  // The hooks are the caller's, for this construction only: the problem
  // outlives them (its evaluations take a token, LogPosterior's overload).
  s.options.fit.cancelled = nullptr;
  s.options.fit.on_progress = nullptr;
  s.options.sampler.cancelled = nullptr;
  s.options.sampler.on_step = nullptr;
  const CancelToken token(options.fit.cancelled);
  const FitGeometry& g = *options.fit.geometry;
  s.band = AdmissibleAlphaBand(g, options.priors.alpha_band_m);
  if (!g.polygon_m.empty()) {
    const BlockGeometry geometry = PolygonBlock(g.polygon_m);
    s.theory = {geometry.alpha, geometry.p, geometry.mu_general};
  } else {
    s.theory = RectangleBlock(g.width_m, g.height_m, g.chamfer_m).params();
  }
  s.f = ExtractFreeRocking(record, options.fit.features, options.fit.cancelled);
  s.noise = s.f.noise_rad;
  if (!(s.noise > 0.0)) {
    throw FitError(record.source + ": the record has no measurable noise (estimated 0 rad): the likelihood's noise "
                   "prior is set from it");
  }
  s.forced = record.has_table() && MaxAbs(record.table_accel_mps2) > kForcedTableAccel;
  s.complex = options.method == FitMethod::kTrajectory && options.model == ModelKind::kComplex;

  if (s.f.max_abs_theta >= s.band.hi) {
    throw FitError(record.source + ": the block overturns (|theta| reaches " + fit_detail::Num(s.f.max_abs_theta, 4) +
                   " rad, beyond the admissible alpha " + fit_detail::Num(s.band.hi, 4) + " rad): there is no rocking to sample");
  }
  if (s.f.impact_time_s.empty() || s.f.max_abs_theta < s.f.min_peak_rad) {
    throw FitError(record.source + ": the block never rocks (max |theta| " + fit_detail::Num(s.f.max_abs_theta, 3) +
                   " rad, estimated noise " + fit_detail::Num(s.noise, 3) + " rad)");
  }
  // The point fit gives the walkers their start; when it fails (a minimum
  // outside the band, no convergence) they start at the geometry.
  FitOptions fo = options.fit;
  fo.alpha_band_m = options.priors.alpha_band_m;
  fo.on_progress = nullptr;
  if (point != nullptr) {
    s.point = *point;
    s.point_fitted = true;
  } else {
    try {
      s.point = options.method == FitMethod::kImpacts ? FitImpacts(record, fo) : FitTrajectory(record, fo);
      s.point_fitted = true;
    } catch (const FitError& e) {
      s.point_error = e.what();
    }
  }

  if (options.method == FitMethod::kImpacts) {
    if (s.forced) {
      throw FitError(record.source + ": not free rocking (table acceleration up to " +
                     fit_detail::Num(MaxAbs(record.table_accel_mps2), 3) + " m/s^2): use the trajectory method");
    }
    const std::size_t usable = s.f.impact_time_s.size() - (s.f.r0_rad ? 0 : 1);
    if (s.f.impact_time_s.empty() || static_cast<int>(usable) < options.fit.min_impacts || s.f.peak_rad.empty()) {
      throw FitError(record.source + ": only " + std::to_string(s.f.impact_time_s.size()) +
                     " usable impacts (the impacts likelihood needs " + std::to_string(options.fit.min_impacts) +
                     " after the amplitude it starts from)");
    }
    s.release = s.f.release_time_s.has_value() && s.f.r0_rad.has_value();
  } else {
    const std::size_t head = std::min<std::size_t>(record.size(), 20);
    bool at_rest = true;
    for (std::size_t k = 0; k < head; ++k) at_rest = at_rest && std::abs(record.theta[k]) < s.f.hysteresis_rad;
    s.from_hold = !at_rest && s.f.release_time_s.has_value() && s.f.r0_rad.has_value();
    if (!at_rest && !s.from_hold) {
      throw FitError(record.source + ": the trajectory likelihood needs a record that starts at rest (forced) "
                     "or holds the block before releasing it (free)");
    }
    if (at_rest && !s.forced) {
      throw FitError(record.source + ": the record starts at rest and has no table motion to start the rocking");
    }
    s.first = s.from_hold ? s.f.hold_start_index : 0;
    s.theta0 = s.from_hold ? s.f.first_sign * *s.f.r0_rad : 0.0;
    if (s.forced) {
      s.table = std::make_unique<SampledAcceleration>(record.table_time_s, record.table_accel_mps2,
                                                    options.fit.table_interpolation);
    }
  }

  // Coordinates and their prior support.
  const PosteriorPriors& pr = options.priors;
  s.names = {"alpha", "p", "mu"};
  std::vector<double> lo = {s.band.lo, s.theory.p * (1.0 - pr.p_range), pr.mu_min};
  std::vector<double> hi = {s.band.hi, s.theory.p * (1.0 + pr.p_range), pr.mu_max};
  if (s.complex) {
    s.names.push_back("l");
    lo.push_back(pr.log10_l_min);
    hi.push_back(pr.log10_l_max);
  }
  if (pr.per_impact_mu) {
    s.i_sigma_mu = static_cast<int>(s.names.size());
    s.names.push_back("sigma_mu");
    lo.push_back(0.0);
    hi.push_back(pr.sigma_mu_max);
  }
  s.i_sigma = static_cast<int>(s.names.size());
  s.names.push_back("sigma");
  lo.push_back(s.noise / 10.0);
  hi.push_back(s.noise * 10.0);
  s.i_offset = static_cast<int>(s.names.size());
  s.names.push_back("t_offset");
  lo.push_back(-pr.t_offset_s);
  hi.push_back(pr.t_offset_s);
  s.lo = Eigen::Map<Eigen::VectorXd>(lo.data(), static_cast<Eigen::Index>(lo.size()));
  s.hi = Eigen::Map<Eigen::VectorXd>(hi.data(), static_cast<Eigen::Index>(hi.size()));
  SearchStart(s, token);
  impl_ = std::move(impl);
}

const std::vector<std::string>& PosteriorProblem::names() const { return impl_->names; }
int PosteriorProblem::dimension() const { return static_cast<int>(impl_->names.size()); }
double PosteriorProblem::LogPosterior(const Eigen::VectorXd& x) const { return impl_->LogPosterior(x, nullptr); }
double PosteriorProblem::LogPosterior(const Eigen::VectorXd& x, const CancelToken& token) const {
  return impl_->LogPosterior(x, &token);
}
double PosteriorProblem::LogPrior(const Eigen::VectorXd& x) const { return impl_->LogPrior(x); }
const Eigen::VectorXd& PosteriorProblem::lower() const { return impl_->lo; }
const Eigen::VectorXd& PosteriorProblem::upper() const { return impl_->hi; }
const FitResult& PosteriorProblem::point() const { return impl_->point; }
bool PosteriorProblem::point_fitted() const { return impl_->point_fitted; }
std::string PosteriorProblem::point_error() const { return impl_->point_error; }
bool PosteriorProblem::forced() const { return impl_->forced; }

int PosteriorProblem::data_points() const {
  const Impl& s = *impl_;
  if (s.options.method == FitMethod::kImpacts) {
    return static_cast<int>(2 * (s.f.impact_time_s.size() - (s.f.r0_rad ? 0 : 1)) - 1);
  }
  return static_cast<int>(s.record.size() - s.first);
}

Eigen::VectorXd PosteriorProblem::ToReported(const Eigen::VectorXd& x) const {
  Eigen::VectorXd y = x;
  if (impl_->complex) y(3) = std::pow(10.0, x(3));
  return y;
}

Eigen::VectorXd PosteriorProblem::Start() const { return impl_->start; }

bool PosteriorProblem::start_from_scan() const { return impl_->start_from_scan; }

Eigen::VectorXd PosteriorProblem::StartScale() const {
  // About the posterior's own spread where the point fit gives it (its
  // standard errors), so that the ensemble starts near its stationary
  // spread instead of expanding from a point (fewer steps of burn-in).
  const Impl& s = *impl_;
  Eigen::VectorXd scale = 1e-3 * (s.hi - s.lo);
  if (s.point_fitted && !s.start_from_scan) {
    const double se[3] = {s.point.alpha_stderr, s.point.p_stderr, s.point.mu_stderr};
    for (int i = 0; i < 3; ++i) {
      if (std::isfinite(se[i]) && se[i] > 0.0) scale(i) = std::min(se[i], 0.1 * (s.hi(i) - s.lo(i)));
    }
  }
  // sigma from n data: relative standard error 1 / sqrt(2 n).
  if (s.start_from_scan) scale.head(3) = 1e-3 * (s.hi.head(3) - s.lo.head(3));
  scale(s.i_sigma) = s.noise / std::sqrt(2.0 * std::max(1, data_points()));
  if (s.i_sigma_mu >= 0) scale(s.i_sigma_mu) = 0.1 * s.start(s.i_sigma_mu);
  if (s.options.method == FitMethod::kImpacts && !s.f.impact_time_stderr_s.empty()) {
    scale(s.i_offset) = s.f.impact_time_stderr_s[0];
  }
  return scale;
}

// ---- the run -------------------------------------------------------------------

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return kNaN;
  std::sort(v.begin(), v.end());
  const double h = q * static_cast<double>(v.size() - 1);
  const auto i = static_cast<std::size_t>(std::floor(h));
  if (i + 1 >= v.size()) return v.back();
  return v[i] + (h - static_cast<double>(i)) * (v[i + 1] - v[i]);
}

PosteriorResult SamplePosterior(const RockingRecord& record, const PosteriorOptions& options) {
  return SamplePosterior(PosteriorProblem(record, options), options);
}

PosteriorResult SamplePosterior(const PosteriorProblem& problem, const PosteriorOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  const int dim = problem.dimension();
  options.sampler.Validate(dim);
  const int w = options.sampler.walkers;
  // Walkers in a ball about the start: each coordinate start + scale N(0, 1),
  // redrawn (up to 1000 times, the ball halved every 100) until the log
  // posterior is finite. The ball's streams follow the sampler's (past its
  // walkers' indices), so the start depends on the seed alone.
  const Eigen::VectorXd x0 = problem.Start();
  const Eigen::VectorXd scale = problem.StartScale();
  const CancelToken token(options.sampler.cancelled);  // for the ball, on this thread
  if (!std::isfinite(problem.LogPosterior(x0, token))) {
    throw FitError("the posterior is zero at the start point (alpha " + fit_detail::Num(x0(0), 4) + ", p " + fit_detail::Num(x0(1), 4) + ", mu " +
                   fit_detail::Num(x0(2), 4) + "): the model cannot follow the record inside the priors");
  }
  Eigen::MatrixXd start(w, dim);
  for (int k = 0; k < w; ++k) {
    RandomStream rng(options.sampler.seed, static_cast<std::uint64_t>(w + k));
    Eigen::VectorXd x = x0;
    double shrink = 1.0;
    for (int attempt = 0; attempt < 1000; ++attempt) {
      if (attempt > 0 && attempt % 100 == 0) shrink /= 2.0;
      for (int i = 0; i < dim; ++i) x(i) = x0(i) + shrink * scale(i) * rng.Normal();
      if (std::isfinite(problem.LogPosterior(x, token))) break;
      x = x0;
    }
    start.row(k) = x.transpose();
  }

  const EnsembleRun run = RunEnsembleCancellable(
      [&problem](const Eigen::VectorXd& x, const CancelToken& t) { return problem.LogPosterior(x, t); }, start,
      options.sampler);
  const int burn = options.burn_in >= 0 ? options.burn_in : options.sampler.steps / 2;

  PosteriorResult r;
  r.names = problem.names();
  r.method = ToString(options.method);
  r.model = options.method == FitMethod::kImpacts ? "housner" : ToString(options.model);
  r.walkers = w;
  r.steps = options.sampler.steps;
  r.seed = options.sampler.seed;
  r.threads = run.threads;
  r.point_fitted = problem.point_fitted();
  r.start_from = problem.start_from_scan() ? "prior scan" : problem.point_fitted() ? "point fit" : "geometry";
  if (!problem.point_fitted()) r.warnings.push_back("point fit failed, walkers start at the geometry: " + problem.point_error());
  r.diagnostics = Diagnose(run, burn);
  r.problems = ConvergenceProblems(r.diagnostics, options.rule, r.names);

  const int kept = run.steps - burn;
  r.draws.resize(static_cast<Eigen::Index>(kept) * w, dim);
  r.log_posterior.resize(static_cast<Eigen::Index>(kept) * w);
  for (Eigen::Index i = 0; i < r.draws.rows(); ++i) {
    const Eigen::Index row = static_cast<Eigen::Index>(burn) * w + i;
    r.draws.row(i) = problem.ToReported(run.chain.row(row).transpose()).transpose();
    r.log_posterior(i) = run.log_density(row);
  }
  const Eigen::RowVectorXd mean = r.draws.colwise().mean();
  const Eigen::MatrixXd centred = r.draws.rowwise() - mean;
  const Eigen::MatrixXd cov = centred.transpose() * centred / static_cast<double>(r.draws.rows() - 1);
  r.correlation.resize(dim, dim);
  for (int i = 0; i < dim; ++i) {
    for (int j = 0; j < dim; ++j) r.correlation(i, j) = cov(i, j) / std::sqrt(cov(i, i) * cov(j, j));
  }
  for (int i = 0; i < dim; ++i) {
    std::vector<double> col(r.draws.col(i).data(), r.draws.col(i).data() + r.draws.rows());
    ParameterSummary ps;
    ps.name = r.names[static_cast<std::size_t>(i)];
    ps.median = Quantile(col, 0.5);
    ps.ci68_lo = Quantile(col, 0.15865525393145707);
    ps.ci68_hi = Quantile(col, 0.8413447460685429);
    ps.ci95_lo = Quantile(col, 0.025);
    ps.ci95_hi = Quantile(col, 0.975);
    ps.mean = mean(i);
    ps.sd = std::sqrt(cov(i, i));
    ps.rhat = r.diagnostics.rhat[static_cast<std::size_t>(i)];
    ps.ess = r.diagnostics.ess[static_cast<std::size_t>(i)];
    ps.tau = r.diagnostics.tau[static_cast<std::size_t>(i)];
    r.summary.push_back(ps);
  }
  r.runtime_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

std::string PosteriorJson(const PosteriorResult& r) {
  using nlohmann::json;
  auto finite = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  json j;
  json rhat = json::object(), ess = json::object(), tau = json::object(), units = json::object();
  const std::map<std::string, std::string> unit_of = {{"alpha", "rad"}, {"p", "rad/s"}, {"mu", "1"},
                                                      {"l", "1"},       {"sigma", "rad"}, {"t_offset", "s"},
                                                      {"sigma_mu", "1"}};
  for (const ParameterSummary& s : r.summary) {
    j[s.name] = {{"median", s.median}, {"ci68", {s.ci68_lo, s.ci68_hi}}, {"ci95", {s.ci95_lo, s.ci95_hi}},
                 {"sd", s.sd},         {"mean", s.mean}};
    rhat[s.name] = finite(s.rhat);
    ess[s.name] = finite(s.ess);
    tau[s.name] = finite(s.tau);
    const auto u = unit_of.find(s.name);
    units[s.name] = u != unit_of.end() ? u->second : "1";
  }
  // Per-impact restitution: mu is the mean restitution mu_bar; under that
  // name too (docs/identification.md).
  if (j.contains("sigma_mu") && j.contains("mu")) {
    j["mu_bar"] = j["mu"];
    units["mu_bar"] = "1";
  }
  json matrix = json::array();
  for (Eigen::Index i = 0; i < r.correlation.rows(); ++i) {
    json row = json::array();
    for (Eigen::Index k = 0; k < r.correlation.cols(); ++k) row.push_back(finite(r.correlation(i, k)));
    matrix.push_back(row);
  }
  j["parameters"] = r.names;
  j["correlation"] = {{"order", r.names}, {"matrix", matrix}};
  j["rhat"] = rhat;
  j["ess"] = ess;
  j["tau"] = tau;
  j["acceptance"] = r.diagnostics.acceptance;
  j["walkers"] = r.walkers;
  j["steps"] = r.steps;
  j["burn_in"] = r.diagnostics.burn_in;
  j["draws"] = r.draws.rows();
  j["seed"] = r.seed;
  j["threads"] = r.threads;
  j["method"] = r.method;
  j["model"] = r.model;
  j["converged"] = r.converged();
  j["problems"] = r.problems;
  j["start"] = r.start_from;
  j["warnings"] = r.warnings;
  j["runtime"] = r.runtime_s;
  units["tau"] = "steps";
  units["runtime"] = "s";
  j["units"] = units;
  return j.dump();
}

}  // namespace rocklab::model
