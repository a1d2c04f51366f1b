#include "model/fit.h"

#include "model/numbers.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <numeric>
#include <sstream>

#include <Eigen/Dense>
#include <unsupported/Eigen/LevenbergMarquardt>
#include <unsupported/Eigen/NumericalDiff>

#include "model/excitation.h"
#include "model/free_rocking.h"
#include "model/rocking_model.h"

namespace rocklab::model {
namespace {

using detail::kPi;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string Num(double v, int digits = 6) {
  std::ostringstream out;
  out.precision(digits);
  out << v;
  return out.str();
}

double Median(std::vector<double> v) {
  if (v.empty()) return kNaN;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// White-noise standard deviation of theta from the median absolute second
// difference: for white noise var(d2) = 6 sigma^2, and the smooth motion adds
// only theta'' dt^2 (about 1e-5 rad at 500 Hz), so the robust scale of d2 is
// the noise. Impacts (kinks) are a few samples and do not move the median.
double EstimateNoise(const std::vector<double>& theta) {
  if (theta.size() < 5) return 0.0;
  std::vector<double> d2(theta.size() - 2);
  for (std::size_t k = 1; k + 1 < theta.size(); ++k) {
    d2[k - 1] = std::abs(theta[k + 1] - 2.0 * theta[k] + theta[k - 1]);
  }
  return 1.4826 * Median(std::move(d2)) / std::sqrt(6.0);
}

// Index range [lo, hi) of the samples with time in [t0, t1].
std::pair<std::size_t, std::size_t> Range(const std::vector<double>& t, double t0, double t1) {
  const auto lo = std::lower_bound(t.begin(), t.end(), t0) - t.begin();
  const auto hi = std::upper_bound(t.begin(), t.end(), t1) - t.begin();
  return {static_cast<std::size_t>(lo), static_cast<std::size_t>(hi)};
}

// Golden-section minimisation of f on [a, b].
template <typename F>
double GoldenMin(const F& f, double a, double b, int iterations = 60) {
  const double g = (std::sqrt(5.0) - 1.0) / 2.0;
  double c = b - g * (b - a);
  double d = a + g * (b - a);
  double fc = f(c);
  double fd = f(d);
  for (int i = 0; i < iterations && (b - a) > 1e-12 * (1.0 + std::abs(a)); ++i) {
    if (fc < fd) {
      b = d;
      d = c;
      fd = fc;
      c = b - g * (b - a);
      fc = f(c);
    } else {
      a = c;
      c = d;
      fc = fd;
      d = a + g * (b - a);
      fd = f(d);
    }
  }
  return (a + b) / 2;
}

// Minimises a piecewise-smooth 1-D function: a grid of `per_step` points per
// `step` over [a, b], then golden section around the best grid point.
template <typename F>
double GridThenGolden(const F& f, double a, double b, double step, int per_step) {
  const int n = std::max(2, static_cast<int>(std::ceil((b - a) / step * per_step)) + 1);
  double best_x = a;
  double best_f = std::numeric_limits<double>::infinity();
  for (int i = 0; i < n; ++i) {
    const double x = a + (b - a) * i / (n - 1);
    const double v = f(x);
    if (v < best_f) {
      best_f = v;
      best_x = x;
    }
  }
  const double h = (b - a) / (n - 1);
  return GoldenMin(f, std::max(a, best_x - h), std::min(b, best_x + h));
}

// Residual sum of squares of theta = s u + c u^2 (through the origin) on
// one side of a crossing; `ok` false when fewer than 3 samples.
struct SideFit {
  double s1{}, s2{}, s3{}, s4{}, sy{}, suy{}, su2y{}, syy{};
  int n{};
  void Add(double u, double y) {
    const double u2 = u * u;
    s2 += u2;
    s3 += u2 * u;
    s4 += u2 * u2;
    suy += u * y;
    su2y += u2 * y;
    syy += y * y;
    ++n;
  }
  double Rss() const {
    // Normal equations [s2 s3; s3 s4] [s; c] = [suy; su2y].
    const double det = s2 * s4 - s3 * s3;
    if (n < 3 || !(det > 0.0)) return syy;
    const double s = (suy * s4 - su2y * s3) / det;
    const double c = (s2 * su2y - s3 * suy) / det;
    return syy - s * suy - c * su2y;
  }
};

// Impact time within [t_i, t_j]: the common root tc of two local quadratics
// theta = s_-(t - tc) + c_-(t - tc)^2 before and s_+(t - tc) + c_+(t - tc)^2
// after, by least squares over the samples in [t_i - w_before, t_j + w_after].
// Two sides, because the impact is a kink: the angular velocity is multiplied
// by mu and the curvature changes sign, so one polynomial through the
// crossing would be biased towards the slower side.
double FitCrossing(const RockingRecord& r, std::size_t i, std::size_t j, double w_before,
                   double w_after) {
  // Plain variables, not a structured binding: the lambda captures them, and
  // clang before 16 cannot capture a binding (the sanitizer build uses clang).
  const std::pair<std::size_t, std::size_t> range =
      Range(r.time_s, r.time_s[i] - w_before, r.time_s[j] + w_after);
  const std::size_t lo = range.first;
  const std::size_t hi = range.second;
  auto rss = [&](double tc) {
    SideFit before;
    SideFit after;
    for (std::size_t k = lo; k < hi; ++k) {
      const double u = r.time_s[k] - tc;
      (u < 0.0 ? before : after).Add(u, r.theta[k]);
    }
    return before.Rss() + after.Rss();
  };
  const double dt = (r.time_s[j] - r.time_s[i]) / static_cast<double>(j - i);
  if (i + 1 == j && (hi - lo) < 6) {
    // Too few samples for the fit: linear interpolation.
    const double a = r.theta[i];
    const double b = r.theta[j];
    return r.time_s[i] + (r.time_s[j] - r.time_s[i]) * a / (a - b);
  }
  return GridThenGolden(rss, r.time_s[i], r.time_s[j], dt, 8);
}

// Least-squares polynomial of degree `degree` in u = (t - centre) / half on
// the samples [lo, hi) of s * theta; coefficients lowest first.
Eigen::VectorXd PolyFit(const RockingRecord& r, std::size_t lo, std::size_t hi, double centre,
                        double half, double s, int degree) {
  const auto n = static_cast<Eigen::Index>(hi - lo);
  Eigen::MatrixXd a(n, degree + 1);
  Eigen::VectorXd y(n);
  for (Eigen::Index k = 0; k < n; ++k) {
    const double u = (r.time_s[lo + k] - centre) / half;
    double pw = 1.0;
    for (int d = 0; d <= degree; ++d) {
      a(k, d) = pw;
      pw *= u;
    }
    y(k) = s * r.theta[lo + k];
  }
  return a.colPivHouseholderQr().solve(y);
}

double PolyValue(const Eigen::VectorXd& c, double u) {
  double v = 0.0;
  for (Eigen::Index d = c.size() - 1; d >= 0; --d) v = v * u + c(d);
  return v;
}

// Peak of s * theta on [t_a, t_b]: a quartic least-squares fit over the
// middle half of the interval (free rocking is symmetric about the peak, so
// the window is centred on the midpoint), maximised by Newton from the
// centre. A quartic, not a parabola: near the peak theta follows
// alpha - (alpha - r) cosh(p t), whose t^4 term biases a parabola's apex by
// about 1e-4 rad over such a window.
double FitPeak(const RockingRecord& r, double t_a, double t_b, double s) {
  const double centre = (t_a + t_b) / 2;
  const double half = (t_b - t_a) / 4;
  const auto [lo, hi] = Range(r.time_s, centre - half, centre + half);
  double sample_max = -std::numeric_limits<double>::infinity();
  for (std::size_t k = lo; k < hi; ++k) sample_max = std::max(sample_max, s * r.theta[k]);
  if (hi - lo < 9) return sample_max;
  const Eigen::VectorXd c = PolyFit(r, lo, hi, centre, half, s, 4);
  double u = 0.0;
  for (int it = 0; it < 30; ++it) {
    const double d1 = c(1) + 2 * c(2) * u + 3 * c(3) * u * u + 4 * c(4) * u * u * u;
    const double d2 = 2 * c(2) + 6 * c(3) * u + 12 * c(4) * u * u;
    if (!(d2 < 0.0)) break;
    const double step = d1 / d2;
    u = std::clamp(u - step, -1.0, 1.0);
    if (std::abs(step) < 1e-12) break;
  }
  const double v = PolyValue(c, u);
  // A fit that disagrees wildly with the samples (too few, outliers) is
  // not trusted.
  return std::isfinite(v) && std::abs(v - sample_max) < 0.2 * std::abs(sample_max) ? v : sample_max;
}

// Release after a hold: s * theta = c before t_r and c - a (t - t_r)^2
// after (a released block starts with zero velocity; over the first 3 % of
// the fall the next term, of order p^2 u^2 / 12 relative, is below 1e-4 rad).
// c and a by linear least squares for each t_r, t_r by a 1-D search, and
// its standard error from the curvature of the profile RSS(t_r).
struct Onset {
  double t_r{};
  double t_r_stderr{};
  double level{};  // c, rad (magnitude)
};
Onset FitOnset(const RockingRecord& r, std::size_t lo, std::size_t hi, double tr_lo, double tr_hi,
               double s) {
  auto solve = [&](double tr, double* level) {
    double s00 = 0, s01 = 0, s11 = 0, sy0 = 0, sy1 = 0, syy = 0;
    for (std::size_t k = lo; k < hi; ++k) {
      const double u = std::max(0.0, r.time_s[k] - tr);
      const double b = -u * u;
      const double y = s * r.theta[k];
      s00 += 1.0;
      s01 += b;
      s11 += b * b;
      sy0 += y;
      sy1 += b * y;
      syy += y * y;
    }
    const double det = s00 * s11 - s01 * s01;
    if (!(det > 0.0)) return syy;
    const double c = (sy0 * s11 - sy1 * s01) / det;
    const double a = (s00 * sy1 - s01 * sy0) / det;
    if (level) *level = c;
    return syy - c * sy0 - a * sy1;
  };
  const double dt = (r.time_s[hi - 1] - r.time_s[lo]) / static_cast<double>(hi - lo - 1);
  Onset o;
  auto rss = [&](double tr) { return solve(tr, nullptr); };
  o.t_r = GridThenGolden(rss, tr_lo, tr_hi, dt, 2);
  const double rss0 = solve(o.t_r, &o.level);
  const double s2 = rss0 / static_cast<double>(hi - lo - 3);
  const double d = dt;
  const double curvature = (rss(o.t_r + d) - 2.0 * rss0 + rss(o.t_r - d)) / (d * d);
  o.t_r_stderr = curvature > 0.0 ? std::sqrt(2.0 * s2 / curvature) : kNaN;
  return o;
}

// --- Levenberg-Marquardt driver ---------------------------------------------

struct LmOutcome {
  Eigen::VectorXd x;
  Eigen::VectorXd residuals;
  Eigen::MatrixXd jacobian;
  int iterations{};
  int evaluations{};
  Eigen::LevenbergMarquardtSpace::Status status{};
};

// Runs Eigen's LM on `functor` (an Eigen::DenseFunctor with a const
// operator()(x, fvec) and an `evaluations()` counter) with central
// differences of relative step sqrt(epsfcn), reporting every iteration.
template <typename Functor>
LmOutcome RunLm(const Functor& functor, Eigen::VectorXd x, double epsfcn, double xtol,
                double ftol, int max_evaluations, const FitOptions& options,
                std::chrono::steady_clock::time_point start) {
  Eigen::NumericalDiff<Functor, Eigen::Central> numdiff(functor, epsfcn);
  Eigen::LevenbergMarquardt<Eigen::NumericalDiff<Functor, Eigen::Central>> lm(numdiff);
  lm.setXtol(xtol);
  lm.setFtol(ftol);
  lm.setMaxfev(max_evaluations);
  LmOutcome out;
  out.status = lm.minimizeInit(x);
  int iteration = 0;
  if (out.status != Eigen::LevenbergMarquardtSpace::ImproperInputParameters) {
    do {
      out.status = lm.minimizeOneStep(x);
      ++iteration;
      if (options.on_progress) {
        FitProgress p;
        p.iteration = iteration;
        p.evaluations = numdiff.evaluations();
        p.rms = lm.fnorm() / std::sqrt(static_cast<double>(functor.values()));
        p.x = x;
        p.elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        options.on_progress(p);
      }
    } while (out.status == Eigen::LevenbergMarquardtSpace::Running);
  }
  out.x = x;
  out.residuals.resize(functor.values());
  functor(x, out.residuals);
  out.jacobian.resize(functor.values(), x.size());
  numdiff.df(x, out.jacobian);
  out.iterations = iteration;
  out.evaluations = numdiff.evaluations();
  return out;
}

// s^2 (J^T J)^-1 with s^2 = RSS / (m - n); NaN where J^T J is singular.
Eigen::MatrixXd Covariance(const LmOutcome& o) {
  const auto m = o.residuals.size();
  const auto n = o.x.size();
  const double s2 = o.residuals.squaredNorm() / static_cast<double>(std::max<Eigen::Index>(1, m - n));
  const Eigen::MatrixXd jtj = o.jacobian.transpose() * o.jacobian;
  Eigen::FullPivLU<Eigen::MatrixXd> lu(jtj);
  if (!lu.isInvertible()) return Eigen::MatrixXd::Constant(n, n, kNaN);
  return s2 * lu.inverse();
}

bool LmConverged(Eigen::LevenbergMarquardtSpace::Status s) {
  using namespace Eigen::LevenbergMarquardtSpace;
  return s == RelativeReductionTooSmall || s == RelativeErrorTooSmall ||
         s == RelativeErrorAndReductionTooSmall || s == CosinusTooSmall || s == FtolTooSmall ||
         s == XtolTooSmall || s == GtolTooSmall;
}

// --- impacts method ----------------------------------------------------------

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

double MaxAbsTable(const RockingRecord& r) {
  double m = 0.0;
  for (double a : r.table_accel_mps2) m = std::max(m, std::abs(a));
  return m;
}

// Theory and admissible band from the geometry, when there is one.
void SetGeometry(const FitOptions& options, FitResult& out) {
  if (!options.geometry) return;
  const FitGeometry& g = *options.geometry;
  out.theory = RectangleBlock(g.width_m, g.height_m, g.chamfer_m).params();
  out.band = AdmissibleAlphaBand(g, options.alpha_band_m);
}

// Never rocks / overturns: the checks both methods share.
void CheckRocks(const RockingRecord& record, const FreeRockingFeatures& f, const FitResult& out,
                const FitOptions& options) {
  const double limit = out.band ? out.band->hi : options.features.overturn_rad;
  if (f.max_abs_theta > limit) {
    throw FitError(record.source + ": the block overturns (|theta| reaches " + Num(f.max_abs_theta, 4) +
                   " rad at " + Num(f.max_abs_theta_time_s, 5) + " s, beyond " +
                   (out.band ? "the admissible alpha " : "") + Num(limit, 4) +
                   " rad): there is no rocking response to fit");
  }
  if (f.max_abs_theta < f.min_peak_rad || (f.impact_time_s.empty() && f.peak_rad.empty())) {
    throw FitError(record.source + ": the block never rocks (max |theta| " + Num(f.max_abs_theta, 3) +
                   " rad, " + std::to_string(f.impact_time_s.size()) +
                   " zero crossings beyond the noise, estimated noise " + Num(f.noise_rad, 3) + " rad)");
  }
}

}  // namespace

// --- public ------------------------------------------------------------------

const char* ToString(QuarterTime q) { return q == QuarterTime::kExact ? "exact" : "slender"; }
const char* ToString(FitMethod m) { return m == FitMethod::kImpacts ? "impacts" : "trajectory"; }

QuarterTime ParseQuarterTime(const std::string& name) {
  if (name == "exact") return QuarterTime::kExact;
  if (name == "slender") return QuarterTime::kSlender;
  throw std::invalid_argument("quarter time must be exact or slender, got '" + name + "'");
}

FitMethod ParseFitMethod(const std::string& name) {
  if (name == "impacts") return FitMethod::kImpacts;
  if (name == "trajectory") return FitMethod::kTrajectory;
  throw std::invalid_argument("method must be impacts or trajectory, got '" + name + "'");
}

double QuarterTimeOf(QuarterTime kind, double alpha, double p, double r) {
  return kind == QuarterTime::kExact ? QuarterTimeExact(alpha, p, r) : QuarterTimeSlender(alpha, p, r);
}

AlphaBand AdmissibleAlphaBand(const FitGeometry& g, double band_m) {
  if (!(band_m >= 0.0) || !std::isfinite(band_m)) {
    throw std::invalid_argument("alpha band must be >= 0 m, got " + Num(band_m));
  }
  if (!(g.width_m - 2.0 * band_m - 2.0 * g.chamfer_m > 0.0)) {
    throw std::invalid_argument("alpha band " + Num(band_m) + " m leaves no half-width of the base (width " +
                                Num(g.width_m) + " m, chamfer " + Num(g.chamfer_m) + " m)");
  }
  AlphaBand b;
  b.band_m = band_m;
  b.geometric = RectangleBlock(g.width_m, g.height_m, g.chamfer_m).alpha;
  b.lo = RectangleBlock(g.width_m - 2.0 * band_m, g.height_m, g.chamfer_m).alpha;
  b.hi = RectangleBlock(g.width_m + 2.0 * band_m, g.height_m, g.chamfer_m).alpha;
  return b;
}

void FitOptions::Validate() const {
  auto bad = [](const std::string& what) { throw std::invalid_argument(what); };
  if (!(alpha_band_m >= 0.0)) bad("alpha band must be >= 0 m, got " + Num(alpha_band_m));
  if (min_impacts < 3) bad("min impacts must be >= 3, got " + std::to_string(min_impacts));
  if (!(rtol > 0.0 && rtol < 1e-3)) bad("rtol must be in (0, 1e-3), got " + Num(rtol));
  if (max_evaluations < 10) bad("max evaluations must be >= 10");
  if (!(features.hysteresis_rad >= 0.0)) bad("hysteresis must be >= 0 rad");
  if (!(features.crossing_window_s > 0.0)) bad("crossing window must be > 0 s");
  if (!(features.min_peak_rad >= 0.0)) bad("min peak must be >= 0 rad");
  if (!(features.min_hold_s >= 0.0)) bad("min hold must be >= 0 s");
  if (!(features.overturn_rad > 0.0)) bad("overturn angle must be > 0 rad");
  if (start) start->Validate();
}

FreeRockingFeatures ExtractFreeRocking(const RockingRecord& r, const FeatureOptions& options) {
  FreeRockingFeatures f;
  const std::size_t n = r.size();
  if (n < 5) return f;
  f.noise_rad = EstimateNoise(r.theta);
  f.hysteresis_rad = options.hysteresis_rad > 0 ? options.hysteresis_rad : std::max(1e-7, 5.0 * f.noise_rad);
  f.min_peak_rad = options.min_peak_rad > 0 ? options.min_peak_rad
                                            : std::max(4.0 * f.hysteresis_rad, 20.0 * f.noise_rad);
  for (std::size_t k = 0; k < n; ++k) {
    if (std::abs(r.theta[k]) > f.max_abs_theta) {
      f.max_abs_theta = std::abs(r.theta[k]);
      f.max_abs_theta_time_s = r.time_s[k];
    }
  }

  // Crossing brackets [i, j]: theta leaves one side of the +-h band at i and
  // enters the other at j.
  const double h = f.hysteresis_rad;
  std::vector<std::pair<std::size_t, std::size_t>> brackets;
  int side = 0;
  std::size_t last = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const int s = r.theta[k] > h ? 1 : (r.theta[k] < -h ? -1 : 0);
    if (s == 0) continue;
    if (side == 0) f.first_sign = s;
    if (side != 0 && s != side) brackets.emplace_back(last, k);
    side = s;
    last = k;
  }
  if (brackets.empty()) return f;

  // Sub-sample crossing times, the window limited to a quarter of the
  // distance to the neighbouring crossings (so it never reaches a peak).
  std::vector<double> mid(brackets.size());
  for (std::size_t c = 0; c < brackets.size(); ++c) {
    mid[c] = (r.time_s[brackets[c].first] + r.time_s[brackets[c].second]) / 2;
  }
  std::vector<double> crossings(brackets.size());
  for (std::size_t c = 0; c < brackets.size(); ++c) {
    const double before = c > 0 ? 0.25 * (mid[c] - mid[c - 1]) : options.crossing_window_s;
    const double after = c + 1 < brackets.size() ? 0.25 * (mid[c + 1] - mid[c]) : options.crossing_window_s;
    crossings[c] = FitCrossing(r, brackets[c].first, brackets[c].second,
                               std::min(options.crossing_window_s, before),
                               std::min(options.crossing_window_s, after));
  }

  // Peaks between consecutive crossings; the usable decay ends at the first
  // peak below min_peak (the block settling, where timing is lost in noise).
  f.impact_time_s.push_back(crossings[0]);
  int sign = -f.first_sign;  // side after the first impact
  for (std::size_t c = 0; c + 1 < crossings.size(); ++c) {
    const double peak = FitPeak(r, crossings[c], crossings[c + 1], sign);
    if (!(peak >= f.min_peak_rad)) break;
    f.peak_rad.push_back(peak);
    f.impact_time_s.push_back(crossings[c + 1]);
    sign = -sign;
  }

  // Before the first impact: a release after a hold, or a motion peak.
  const std::size_t i1 = brackets[0].first;
  const double s0 = f.first_sign;
  std::size_t m = 0;
  for (std::size_t k = 0; k <= i1; ++k) {
    if (s0 * r.theta[k] > s0 * r.theta[m]) m = k;
  }
  const double top = s0 * r.theta[m];
  const double drop = 8.0 * f.noise_rad + 1e-9;
  std::size_t hold_lo = m;
  while (hold_lo > 0 && s0 * r.theta[hold_lo - 1] >= top - drop) --hold_lo;
  std::size_t moving = m;  // first sample clearly below the hold after m
  while (moving < i1 && s0 * r.theta[moving] >= top - drop) ++moving;
  // The onset window: the hold (at most its last 0.5 s) and the first 3 % of
  // the fall, where the u^2, u^4 model holds.
  std::size_t fall_end = moving;
  while (fall_end < i1 && s0 * r.theta[fall_end] > 0.97 * top) ++fall_end;
  const double t_moving = r.time_s[moving];
  const std::size_t lo = std::max(hold_lo, Range(r.time_s, t_moving - 0.5, t_moving).first);
  if (top > f.min_peak_rad && fall_end > lo + 8) {
    const double tr_lo = std::max(r.time_s[lo], t_moving - 0.3);
    const Onset o = FitOnset(r, lo, fall_end + 1, tr_lo, t_moving, s0);
    if (o.t_r - r.time_s[hold_lo] >= options.min_hold_s) {
      f.release_time_s = o.t_r;
      f.release_time_stderr_s = o.t_r_stderr;
      f.r0_rad = o.level;
      f.hold_start_index = hold_lo;
      return f;
    }
  }
  // A motion peak inside the first segment with samples on both sides.
  const double half = (crossings[0] - r.time_s[m]);
  if (top > f.min_peak_rad && r.time_s[m] - half >= r.time_s[0] && m > hold_lo) {
    f.r0_rad = FitPeak(r, r.time_s[m] - half, crossings[0], s0);
  }
  return f;
}

FitResult FitImpacts(const RockingRecord& record, const FitOptions& options) {
  options.Validate();
  const auto start = std::chrono::steady_clock::now();
  FitResult out;
  out.method = FitMethod::kImpacts;
  out.quarter_time = options.quarter_time;
  SetGeometry(options, out);
  out.features = ExtractFreeRocking(record, options.features);
  const FreeRockingFeatures& f = out.features;
  CheckRocks(record, f, out, options);

  const int n_impacts = static_cast<int>(f.impact_time_s.size());
  if (n_impacts < options.min_impacts) {
    std::string times;
    for (double t : f.impact_time_s) times += (times.empty() ? "" : ", ") + Num(t, 5);
    throw FitError(record.source + ": only " + std::to_string(n_impacts) +
                   " usable impacts (at " + (times.empty() ? "none" : times + " s") +
                   "); the impacts method needs at least " + std::to_string(options.min_impacts) +
                   " impacts of free rocking with peaks above " + Num(f.min_peak_rad, 3) + " rad");
  }
  if (record.has_table() && MaxAbsTable(record) > 0.05) {
    out.warnings.push_back("the table acceleration reaches " + Num(MaxAbsTable(record), 3) +
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

namespace {

// Residuals theta_model(t_k) - theta_k over the samples [first, n) for
// x = (alpha, p, mu[, release time]). Before a fitted release the model
// holds at the release level.
struct TrajectoryFunctor : Eigen::DenseFunctor<double> {
  TrajectoryFunctor(const RockingRecord& record, std::size_t first, const Forcing& forcing,
                    bool from_hold, double theta0, double rtol)
      : Eigen::DenseFunctor<double>(from_hold ? 4 : 3, static_cast<int>(record.size() - first)),
        record_(&record),
        first_(first),
        forcing_(&forcing),
        from_hold_(from_hold),
        theta0_(theta0) {
    model_options_.rtol = rtol;
    model_options_.atol = 1e-10;
  }
  int operator()(const Eigen::VectorXd& x, Eigen::VectorXd& f) const {
    ++*count_;
    BlockParams bp;
    bp.alpha = std::clamp(x(0), 1e-4, kPi / 2 - 1e-3);
    bp.p = std::max(x(1), 0.05);
    bp.mu = std::clamp(x(2), 0.05, 1.0);
    const double penalty =
        std::abs(bp.alpha - x(0)) + std::abs(bp.p - x(1)) / 10 + std::abs(bp.mu - x(2));
    const std::vector<double>& t = record_->time_s;
    const std::vector<double>& th = record_->theta;
    try {
      auto model = RockingModel::Create(ModelKind::kHousner, bp, model_options_);
      std::size_t k = first_;
      if (from_hold_) {
        const double tr = x(3);
        for (; k < t.size() && t[k] <= tr; ++k) f(static_cast<Eigen::Index>(k - first_)) = theta0_ - th[k];
        model->Reset(tr, theta0_, 0.0);
      } else {
        model->Reset(t[first_], 0.0, 0.0);
      }
      for (; k < t.size(); ++k) {
        model->AdvanceTo(t[k], *forcing_);
        f(static_cast<Eigen::Index>(k - first_)) = model->state().theta - th[k] + penalty;
      }
    } catch (const std::exception&) {
      f.setConstant(1.0);  // a failed run: a step LM must reject
    }
    return 0;
  }
  int evaluations() const { return *count_; }

  const RockingRecord* record_;  // non-owning; outlives the fit
  std::size_t first_;
  const Forcing* forcing_;  // non-owning; outlives the fit
  bool from_hold_;
  double theta0_;
  ModelOptions model_options_;
  std::shared_ptr<int> count_ = std::make_shared<int>(0);  // shared: NumericalDiff copies the functor
};

}  // namespace

FitResult FitTrajectory(const RockingRecord& record, const FitOptions& options) {
  options.Validate();
  const auto start = std::chrono::steady_clock::now();
  FitResult out;
  out.method = FitMethod::kTrajectory;
  out.quarter_time = options.quarter_time;
  SetGeometry(options, out);
  out.features = ExtractFreeRocking(record, options.features);
  const FreeRockingFeatures& f = out.features;
  CheckRocks(record, f, out, options);
  out.forced = record.has_table() && MaxAbsTable(record) > 0.05;

  // Initial state: at rest (a forced test) or a held release (free).
  const std::size_t head = std::min<std::size_t>(record.size(), std::max<std::size_t>(
      20, Range(record.time_s, record.time_s[0], record.time_s[0] + 0.05).second));
  bool at_rest = true;
  for (std::size_t k = 0; k < head; ++k) at_rest = at_rest && std::abs(record.theta[k]) < f.hysteresis_rad;
  const bool from_hold = !at_rest && f.release_time_s.has_value();
  if (!at_rest && !from_hold) {
    throw FitError(record.source + ": the trajectory method needs a record that starts at rest "
                   "(forced test) or holds the block before releasing it (free test); this one "
                   "starts moving at " + Num(record.time_s[0], 5) + " s");
  }
  if (at_rest && !out.forced) {
    throw FitError(record.source + ": the record starts at rest and has no table motion to "
                   "start the rocking (give the table acceleration for a forced test)");
  }

  // Start values.
  BlockParams start_params;
  std::string start_from;
  if (options.start) {
    start_params = *options.start;
    start_from = "given";
  } else if (!out.forced) {
    try {
      FitOptions o = options;
      o.on_progress = nullptr;
      start_params = FitImpacts(record, o).params;
      start_from = "impacts method";
    } catch (const FitError&) {
      if (!out.theory) throw;
    }
  }
  if (start_from.empty()) {
    if (!out.theory) {
      throw FitError(record.source + ": the trajectory method needs start values: give the "
                     "geometry (--rig or --width/--height)");
    }
    start_params = *out.theory;
    start_from = "geometry";
  }

  std::unique_ptr<Forcing> forcing;
  if (record.has_table()) {
    forcing = std::make_unique<SampledAcceleration>(record.table_time_s, record.table_accel_mps2);
  } else {
    forcing = std::make_unique<NoTableMotion>();
  }
  const std::size_t first = from_hold ? f.hold_start_index : 0;
  const double theta0 = from_hold ? f.first_sign * *f.r0_rad : 0.0;
  TrajectoryFunctor functor(record, first, *forcing, from_hold, theta0, options.rtol);
  Eigen::VectorXd x(from_hold ? 4 : 3);
  x(0) = start_params.alpha;
  x(1) = start_params.p;
  x(2) = start_params.mu;
  if (from_hold) x(3) = *f.release_time_s;
  // Whether and when a forced block uplifts hinges on alpha (|u_g''| >
  // g tan(alpha)), so the cost is rugged in alpha and LM can stop in a local
  // minimum. When the first fit does not get down to the noise (1.5 x the
  // estimated noise), it restarts from the best points of a coarse alpha scan
  // (+-15 % in 2.5 % steps, p and mu held) and keeps the lowest cost.
  std::vector<Eigen::VectorXd> starts{x};
  if (out.forced && !options.start) {
    std::vector<std::pair<double, double>> scan;  // (cost, alpha)
    Eigen::VectorXd trial = x;
    Eigen::VectorXd fv(functor.values());
    for (int i = -6; i <= 6; ++i) {
      if (i == 0) continue;
      trial(0) = x(0) * (1.0 + 0.025 * i);
      functor(trial, fv);
      scan.emplace_back(fv.squaredNorm(), trial(0));
    }
    std::sort(scan.begin(), scan.end());
    for (std::size_t i = 0; i < 3 && i < scan.size(); ++i) {
      trial(0) = scan[i].second;
      starts.push_back(trial);
    }
  }
  LmOutcome lm;
  bool have = false;
  int restarts = 0;
  int evaluations = 0;
  for (const Eigen::VectorXd& x_start : starts) {
    LmOutcome trial = RunLm(functor, x_start, 1e-10, 1e-8, 1e-10, options.max_evaluations, options, start);
    evaluations = *functor.count_;
    if (!have || (LmConverged(trial.status) && trial.residuals.squaredNorm() < lm.residuals.squaredNorm()) ||
        !LmConverged(lm.status)) {
      lm = std::move(trial);
      have = true;
    }
    const double rms = std::sqrt(lm.residuals.squaredNorm() / static_cast<double>(lm.residuals.size()));
    if (LmConverged(lm.status) && rms <= 1.5 * f.noise_rad) break;
    ++restarts;
  }
  lm.evaluations = evaluations;
  if (restarts > 0) {
    out.warnings.push_back("restarted " + std::to_string(std::min<int>(restarts, static_cast<int>(starts.size()) - 1)) +
                           " time(s) from an alpha scan (first fit above the noise level)");
  }
  if (!LmConverged(lm.status)) {
    throw FitError(record.source + ": the trajectory fit did not converge in " +
                   std::to_string(lm.evaluations) + " model runs (status " +
                   std::to_string(static_cast<int>(lm.status)) + ", start from the " + start_from + ")");
  }
  out.params = {lm.x(0), lm.x(1), lm.x(2)};
  try {
    out.params.Validate();
  } catch (const std::invalid_argument& e) {
    throw FitError(record.source + ": the trajectory fit left the physical range: " + e.what());
  }
  if (from_hold) out.release_time_s = lm.x(3);
  out.covariance = Covariance(lm);
  out.alpha_stderr = std::sqrt(out.covariance(0, 0));
  out.p_stderr = std::sqrt(out.covariance(1, 1));
  out.mu_stderr = std::sqrt(out.covariance(2, 2));
  out.alpha_p_correlation = out.covariance(0, 1) / (out.alpha_stderr * out.p_stderr);
  out.mu_spread = kNaN;
  out.residuals = static_cast<int>(lm.residuals.size());
  out.dof = out.residuals - static_cast<int>(lm.x.size());
  out.rms_residual = std::sqrt(lm.residuals.squaredNorm() / out.residuals);
  out.iterations = lm.iterations;
  out.evaluations = lm.evaluations;
  out.warnings.push_back("start values from the " + start_from);
  if (out.band && (out.params.alpha < out.band->lo || out.params.alpha > out.band->hi)) {
    throw FitError(record.source + ": fitted alpha " + Num(out.params.alpha, 4) +
                   " rad is outside the admissible band [" + Num(out.band->lo, 4) + ", " +
                   Num(out.band->hi, 4) + "] rad (geometric alpha " + Num(out.band->geometric, 4) +
                   " rad, b +- " + Num(out.band->band_m, 3) +
                   " m): solution rejected (widen with --alpha-band-m)");
  }
  out.runtime_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return out;
}

}  // namespace rocklab::model
