// Features of a free-rocking record: its noise, the impact (zero-crossing)
// times, the peaks between them and the release from a hold, each with its
// standard error from the noise (ExtractFreeRocking, EstimateThetaNoise).
#include <algorithm>
#include <cmath>
#include <limits>

#include "model/fit_impl.h"

namespace rocklab::model {
using namespace fit_detail;
namespace {

// Least squares of theta = s u + c u^2 (through the origin) on one side of
// a crossing; Rss() is syy when fewer than 3 samples.
struct SideFit {
  double s2{}, s3{}, s4{}, suy{}, su2y{}, syy{};
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
  // Normal equations [s2 s3; s3 s4] [s; c] = [suy; su2y]; false when singular.
  bool Solve(double& s, double& c) const {
    const double det = s2 * s4 - s3 * s3;
    if (n < 3 || !(det > 0.0)) return false;
    s = (suy * s4 - su2y * s3) / det;
    c = (s2 * su2y - s3 * suy) / det;
    return true;
  }
  double Rss() const {
    double s = 0.0;
    double c = 0.0;
    if (!Solve(s, c)) return syy;
    return syy - s * suy - c * su2y;
  }
};

struct Crossing {
  double time_s{};
  double stderr_s{};  // from the noise, s
};

// Impact time within [t_i, t_j]: the common root tc of two local quadratics
// theta = s_-(t - tc) + c_-(t - tc)^2 before and s_+(t - tc) + c_+(t - tc)^2
// after, by least squares over the samples in [t_i - w_before, t_j + w_after].
// Two sides, because the impact is a kink: the angular velocity is multiplied
// by mu and the curvature changes sign, so one polynomial through the
// crossing would be biased towards the slower side. The samples need not be
// equally spaced (a missing sample is bridged). Standard error of tc:
// sigma^2 (J^T J)^-1 of the five parameters (s_-, c_-, s_+, c_+, tc) at the
// solution, sigma the record's noise (or the fit's own residual where that
// is significantly larger: LocalNoiseScale).
Crossing FitCrossing(const RockingRecord& r, std::size_t i, std::size_t j, double w_before,
                     double w_after, double noise, const CancelHook& cancelled) {
  // Plain variables, not a structured binding: the lambda captures them, and
  // clang before 16 cannot capture a binding (the sanitizer build uses clang).
  const std::pair<std::size_t, std::size_t> range =
      Range(r.time_s, r.time_s[i] - w_before, r.time_s[j] + w_after);
  const std::size_t lo = range.first;
  const std::size_t hi = range.second;
  auto sides = [&](double tc, SideFit& before, SideFit& after) {
    for (std::size_t k = lo; k < hi; ++k) {
      const double u = r.time_s[k] - tc;
      (u < 0.0 ? before : after).Add(u, r.theta[k]);
    }
  };
  auto rss = [&](double tc) {
    SideFit before;
    SideFit after;
    sides(tc, before, after);
    return before.Rss() + after.Rss();
  };
  Crossing out;
  const double a = r.theta[i];
  const double b = r.theta[j];
  const double span = r.time_s[j] - r.time_s[i];
  if (i + 1 == j && (hi - lo) < 6) {
    // Too few samples for the fit: linear interpolation.
    out.time_s = r.time_s[i] + span * a / (a - b);
    out.stderr_s = noise * span * std::hypot(a, b) / ((a - b) * (a - b));
    return out;
  }
  const double dt = span / static_cast<double>(j - i);
  int calls = 0;  // the cancel hook is polled every 16 passes over the window
  const auto polled = [&](double tc) {
    if (++calls % 16 == 0) ThrowIfCancelled(cancelled);
    return rss(tc);
  };
  out.time_s = GridThenGolden(polled, r.time_s[i], r.time_s[j], dt, 8, kMaxCrossingGridPoints);
  SideFit before;
  SideFit after;
  sides(out.time_s, before, after);
  double sm = 0.0, cm = 0.0, sp = 0.0, cp = 0.0;
  const bool ok = before.Solve(sm, cm) && after.Solve(sp, cp);
  Eigen::Matrix<double, 5, 5> jtj = Eigen::Matrix<double, 5, 5>::Zero();
  for (std::size_t k = lo; k < hi && ok; ++k) {
    const double u = r.time_s[k] - out.time_s;
    Eigen::Matrix<double, 5, 1> row = Eigen::Matrix<double, 5, 1>::Zero();
    if (u < 0.0) {
      row << u, u * u, 0.0, 0.0, -(sm + 2.0 * cm * u);
    } else {
      row << 0.0, 0.0, u, u * u, -(sp + 2.0 * cp * u);
    }
    jtj += row * row.transpose();
  }
  Eigen::FullPivLU<Eigen::Matrix<double, 5, 5>> lu(jtj);
  const double scale = LocalNoiseScale(before.Rss() + after.Rss(), static_cast<int>(hi - lo) - 5, noise);
  out.stderr_s = ok && lu.isInvertible() ? scale * std::sqrt(std::max(0.0, lu.inverse()(4, 4))) : kNaN;
  return out;
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

struct Peak {
  double value_rad{};
  double stderr_rad{};  // from the noise, rad
  bool fitted{};        // false: too few samples or a wild fit, the sample maximum
  bool too_few{};       // fewer than 9 samples in the middle half of the interval
};

// Peak of s * theta on [t_a, t_b]: a quartic least-squares fit over the
// middle half of the interval (free rocking is symmetric about the peak, so
// the window is centred on the midpoint), maximised by Newton from the
// centre. A quartic, not a parabola: near the peak theta follows
// alpha - (alpha - r) cosh(p t), whose t^4 term biases a parabola's apex by
// about 1e-4 rad over such a window. Standard error: the fitted polynomial's
// at the apex, noise * sqrt(v^T (A^T A)^-1 v) with v = (1, u, .., u^4) (the
// apex's own shift does not change the value to first order), the noise
// replaced by the fit's own residual where that is significantly larger
// (the quartic's model error on a quiet record: LocalNoiseScale).
Peak FitPeak(const RockingRecord& r, double t_a, double t_b, double s, double noise) {
  const double centre = (t_a + t_b) / 2;
  const double half = (t_b - t_a) / 4;
  const auto [lo, hi] = Range(r.time_s, centre - half, centre + half);
  double sample_max = -std::numeric_limits<double>::infinity();
  for (std::size_t k = lo; k < hi; ++k) sample_max = std::max(sample_max, s * r.theta[k]);
  if (hi - lo < 9) return {sample_max, noise, false, true};
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
  if (!(std::isfinite(v) && std::abs(v - sample_max) < 0.2 * std::abs(sample_max))) return {sample_max, noise, false, false};
  Eigen::MatrixXd ata = Eigen::MatrixXd::Zero(5, 5);
  for (std::size_t k = lo; k < hi; ++k) {
    const double uk = (r.time_s[k] - centre) / half;
    Eigen::VectorXd row(5);
    row << 1.0, uk, uk * uk, uk * uk * uk, uk * uk * uk * uk;
    ata += row * row.transpose();
  }
  Eigen::VectorXd at(5);
  at << 1.0, u, u * u, u * u * u, u * u * u * u;
  const double var = at.dot(ata.ldlt().solve(at));
  double rss = 0.0;
  for (std::size_t k = lo; k < hi; ++k) {
    const double e = s * r.theta[k] - PolyValue(c, (r.time_s[k] - centre) / half);
    rss += e * e;
  }
  const double scale = LocalNoiseScale(rss, static_cast<int>(hi - lo) - 5, noise);
  return {v, scale * std::sqrt(std::max(0.0, var)), true};
}

// Release after a hold: s * theta = c before t_r and c - a (t - t_r)^2
// after (a released block starts with zero velocity; over the first 3 % of
// the fall the next term, of order p^2 u^2 / 12 relative, is below 1e-4 rad).
// c and a by linear least squares for each t_r, t_r by a 1-D search, and
// its standard error from the curvature of the profile RSS(t_r).
struct Onset {
  double t_r{};
  double t_r_stderr{};
  double level{};         // c, rad (magnitude)
  double level_var_1{};   // var(c) / sigma^2 at t_r, 1
  double rss{};           // residual sum of squares at t_r, rad^2
  int dof{};              // samples - 3
};
Onset FitOnset(const RockingRecord& r, std::size_t lo, std::size_t hi, double tr_lo, double tr_hi,
               double s, const CancelHook& cancelled) {
  auto solve = [&](double tr, double* level, double* level_var_1 = nullptr) {
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
    if (level_var_1) *level_var_1 = s11 / det;
    return syy - c * sy0 - a * sy1;
  };
  const double dt = (r.time_s[hi - 1] - r.time_s[lo]) / static_cast<double>(hi - lo - 1);
  Onset o;
  int calls = 0;  // the cancel hook is polled every 16 passes over the window
  auto rss = [&](double tr) {
    if (++calls % 16 == 0) ThrowIfCancelled(cancelled);
    return solve(tr, nullptr);
  };
  o.t_r = GridThenGolden(rss, tr_lo, tr_hi, dt, 2, kMaxOnsetGridPoints);
  const double rss0 = solve(o.t_r, &o.level, &o.level_var_1);
  const double s2 = rss0 / static_cast<double>(hi - lo - 3);
  o.rss = rss0;
  o.dof = static_cast<int>(hi - lo) - 3;
  const double d = dt;
  const double curvature = (rss(o.t_r + d) - 2.0 * rss0 + rss(o.t_r - d)) / (d * d);
  o.t_r_stderr = curvature > 0.0 ? std::sqrt(2.0 * s2 / curvature) : kNaN;
  return o;
}

}  // namespace

ThetaNoiseEstimate EstimateThetaNoiseDetail(const RockingRecord& record) {
  const std::vector<double>& t = record.time_s;
  const std::vector<double>& th = record.theta;
  ThetaNoiseEstimate e;
  if (t.size() < 7) return e;
  std::vector<double> d2;
  d2.reserve(t.size());
  for (std::size_t k = 1; k + 1 < t.size(); ++k) {
    const double h0 = t[k] - t[k - 1];
    const double h1 = t[k + 1] - t[k];
    if (!(std::abs(h1 - h0) <= 1e-3 * std::max(h0, h1))) continue;  // a gap: not equally spaced
    d2.push_back(std::abs(th[k + 1] - 2.0 * th[k] + th[k - 1]));
  }
  if (d2.size() < 5) return e;
  e.differences = static_cast<int>(d2.size());
  e.sigma_rad = 1.4826 * Median(std::move(d2)) / std::sqrt(6.0);
  e.relative_stderr = 1.42 / std::sqrt(static_cast<double>(e.differences));
  e.dof = 1.0 / (2.0 * e.relative_stderr * e.relative_stderr);
  return e;
}

double EstimateThetaNoise(const RockingRecord& record) { return EstimateThetaNoiseDetail(record).sigma_rad; }

FreeRockingFeatures ExtractFreeRocking(const RockingRecord& r, const FeatureOptions& options,
                                       const CancelHook& cancelled) {
  FreeRockingFeatures f;
  const std::size_t n = r.size();
  if (n < 5) return f;
  if (options.noise_rad > 0.0) {
    f.noise_rad = options.noise_rad;
    f.noise_dof = std::numeric_limits<double>::infinity();
  } else {
    const ThetaNoiseEstimate e = EstimateThetaNoiseDetail(r);
    f.noise_rad = e.sigma_rad;
    f.noise_dof = e.dof;
  }
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
  std::vector<double> crossing_se(brackets.size());
  for (std::size_t c = 0; c < brackets.size(); ++c) {
    ThrowIfCancelled(cancelled);
    const double before = c > 0 ? 0.25 * (mid[c] - mid[c - 1]) : options.crossing_window_s;
    const double after = c + 1 < brackets.size() ? 0.25 * (mid[c + 1] - mid[c]) : options.crossing_window_s;
    const Crossing x = FitCrossing(r, brackets[c].first, brackets[c].second,
                                   std::min(options.crossing_window_s, before),
                                   std::min(options.crossing_window_s, after), f.noise_rad, cancelled);
    crossings[c] = x.time_s;
    crossing_se[c] = x.stderr_s;
  }

  // Peaks between consecutive crossings; the usable decay ends at the first
  // peak below min_peak (the block settling, where timing is lost in noise)
  // or the first interval too short for the quartic (fewer than 9 samples
  // in its middle half: on a noise-free record, where min_peak is no limit,
  // the last impacts come a few samples apart). A peak whose shape the
  // quartic does not follow (a forced record's) keeps its sample maximum,
  // so the half intervals can still say the record is not free rocking.
  f.impact_time_s.push_back(crossings[0]);
  f.impact_time_stderr_s.push_back(crossing_se[0]);
  int sign = -f.first_sign;  // side after the first impact
  for (std::size_t c = 0; c + 1 < crossings.size(); ++c) {
    ThrowIfCancelled(cancelled);
    const Peak peak = FitPeak(r, crossings[c], crossings[c + 1], sign, f.noise_rad);
    if (!(peak.value_rad >= f.min_peak_rad) || peak.too_few) break;
    f.peak_rad.push_back(peak.value_rad);
    f.peak_stderr_rad.push_back(peak.stderr_rad);
    f.impact_time_s.push_back(crossings[c + 1]);
    f.impact_time_stderr_s.push_back(crossing_se[c + 1]);
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
  ThrowIfCancelled(cancelled);
  if (top > f.min_peak_rad && fall_end > lo + 8) {
    const double tr_lo = std::max(r.time_s[lo], t_moving - 0.3);
    const Onset o = FitOnset(r, lo, fall_end + 1, tr_lo, t_moving, s0, cancelled);
    if (o.t_r - r.time_s[hold_lo] >= options.min_hold_s) {
      f.release_time_s = o.t_r;
      f.release_time_stderr_s = o.t_r_stderr;
      f.r0_rad = o.level;
      f.r0_stderr_rad = LocalNoiseScale(o.rss, o.dof, f.noise_rad) * std::sqrt(std::max(0.0, o.level_var_1));
      f.hold_start_index = hold_lo;
      return f;
    }
  }
  // A motion peak inside the first segment with samples on both sides.
  const double half = (crossings[0] - r.time_s[m]);
  if (top > f.min_peak_rad && r.time_s[m] - half >= r.time_s[0] && m > hold_lo) {
    const Peak p0 = FitPeak(r, r.time_s[m] - half, crossings[0], s0, f.noise_rad);
    f.r0_rad = p0.value_rad;
    f.r0_stderr_rad = p0.stderr_rad;
  }
  return f;
}

}  // namespace rocklab::model
