// The fit's options and names, and what both methods share: the opening
// (StartFit: options, geometry, features, the rocks-without-overturning
// check) and the verdict on the residual. The parts are listed in
// model/fit_impl.h.
#include "model/fit.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "model/fit_impl.h"
#include "model/free_rocking.h"

namespace rocklab::model {
namespace fit_detail {
namespace {

// Theory and admissible band from the geometry, when there is one.
void SetGeometry(const FitOptions& options, FitResult& out) {
  if (!options.geometry) return;
  const FitGeometry& g = *options.geometry;
  if (!g.polygon_m.empty()) {
    const BlockGeometry geometry = PolygonBlock(g.polygon_m);
    out.theory = BlockParams{geometry.alpha, geometry.p, geometry.mu_general};
    if (!geometry.symmetric) {
      out.warnings.push_back("asymmetric section: the fit gives one alpha, p, mu for both sides, compared "
                             "with the +x side (minus side alpha " + Num(geometry.minus.alpha, 4) +
                             " rad, p " + Num(geometry.minus.p, 4) + " rad/s)");
    }
  } else {
    out.theory = RectangleBlock(g.width_m, g.height_m, g.chamfer_m).params();
  }
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

double MaxAbsTable(const RockingRecord& r) {
  double m = 0.0;
  for (double a : r.table_accel_mps2) m = std::max(m, std::abs(a));
  return m;
}

FitResult StartFit(FitMethod method, const RockingRecord& record, const FitOptions& options) {
  options.Validate();
  FitResult out;
  out.method = method;
  out.quarter_time = options.quarter_time;
  out.significance = options.significance;
  SetGeometry(options, out);
  out.features = ExtractFreeRocking(record, options.features, options.cancelled);
  out.theta_gaps = record.theta_gaps;
  out.table_gaps = record.table_gaps;
  CheckRocks(record, out.features, out, options);
  return out;
}

double DiagonalChi2(const Eigen::VectorXd& residuals, const std::vector<double>& sigma, double* noise_residual) {
  double chi2 = 0.0;
  double sum_var = 0.0;
  bool ok = !sigma.empty() && static_cast<Eigen::Index>(sigma.size()) == residuals.size();
  for (std::size_t i = 0; ok && i < sigma.size(); ++i) {
    ok = sigma[i] > 0.0 && std::isfinite(sigma[i]);
    if (!ok) break;
    const double z = residuals(static_cast<Eigen::Index>(i)) / sigma[i];
    chi2 += z * z;
    sum_var += sigma[i] * sigma[i];
  }
  *noise_residual = ok ? std::sqrt(sum_var / static_cast<double>(sigma.size())) : kNaN;
  return ok ? chi2 : kNaN;
}

void SetNoiseVerdict(double chi2, double noise_residual, bool lm_converged, FitResult& out) {
  out.stderr_withheld = out.dof < kMinDofForStderr;
  if (out.stderr_withheld) {
    out.alpha_stderr = kNaN;
    out.p_stderr = kNaN;
    out.mu_stderr = kNaN;
    out.alpha_p_correlation = kNaN;
  }
  const bool ok = out.dof >= 1 && std::isfinite(chi2) && std::isfinite(noise_residual);
  out.noise_residual = ok ? noise_residual : kNaN;
  out.chi2 = ok ? chi2 : kNaN;
  out.chi2_per_dof = ok ? chi2 / out.dof : kNaN;
  out.residual_to_noise = ok ? std::sqrt(out.chi2_per_dof) : kNaN;
  out.noise_dof = out.features.noise_dof;
  out.p_value = ok ? FUpperTail(out.chi2_per_dof, out.dof, out.noise_dof) : kNaN;
  out.converged = lm_converged && !(out.p_value < ChiSquareLevel(out));
}

double ChiSquareLevel(const FitResult& out) {
  return out.method == FitMethod::kTrajectory ? 0.5 * out.significance : out.significance;
}

namespace {

// The orthonormal DCT-II basis vectors phi_k(j) = c_k cos(pi k (j + 1/2) / n)
// (c_0 = sqrt(1/n), else sqrt(2/n)), k = 0, 1, ... in turn, by the
// cosines' three-term recurrence (O(n) per vector).
class DctBasisWalk {
 public:
  explicit DctBasisWalk(Eigen::Index n)
      : n_(n), two_cos_(n), previous_(n), current_(Eigen::VectorXd::Ones(n)) {
    for (Eigen::Index j = 0; j < n; ++j) {
      const double c = std::cos(kPi * (static_cast<double>(j) + 0.5) / static_cast<double>(n));
      two_cos_(j) = 2.0 * c;
      previous_(j) = c;  // cos(-theta_j): the recurrence then gives cos(theta_j) next
    }
  }
  Eigen::Index k() const { return k_; }
  // phi_k . v
  double Coefficient(const Eigen::VectorXd& v) const { return Scale() * current_.dot(v); }
  Eigen::RowVectorXd Coefficients(const Eigen::MatrixXd& columns) const {
    return Scale() * (current_.transpose() * columns);
  }
  void Next() {
    Eigen::VectorXd next = two_cos_.cwiseProduct(current_) - previous_;
    previous_.swap(current_);
    current_.swap(next);
    ++k_;
  }

 private:
  double Scale() const { return std::sqrt((k_ == 0 ? 1.0 : 2.0) / static_cast<double>(n_)); }
  Eigen::Index n_;
  Eigen::Index k_{0};
  Eigen::VectorXd two_cos_, previous_, current_;
};

}  // namespace

BandTest LowBandTest(const Eigen::VectorXd& r, const Eigen::MatrixXd& jacobian, Eigen::Index m) {
  BandTest out;
  const Eigen::Index n = r.size(), q = jacobian.cols();
  if (n < 8 || m < 1 || m >= n || jacobian.rows() != n) return out;
  Eigen::FullPivLU<Eigen::MatrixXd> lu(jacobian.transpose() * jacobian);
  if (!lu.isInvertible()) return out;
  double s_low = 0.0;
  Eigen::MatrixXd low = Eigen::MatrixXd::Zero(q, q);  // J^T P_low J
  DctBasisWalk phi(n);
  for (; phi.k() < m; phi.Next()) {
    const double a = phi.Coefficient(r);
    s_low += a * a;
    const Eigen::RowVectorXd aj = phi.Coefficients(jacobian);
    low += aj.transpose() * aj;
  }
  const double s_high = std::max(0.0, r.squaredNorm() - s_low);
  const double tr_low = (lu.inverse() * low).trace();
  out.low = static_cast<int>(m);
  out.dof_low = static_cast<double>(m) - tr_low;
  out.dof_high = static_cast<double>(n - m) - (static_cast<double>(q) - tr_low);
  if (!(out.dof_low >= 1.0) || !(out.dof_high >= 1.0) || !(s_high > 0.0)) return out;
  out.ratio = (s_low / out.dof_low) / (s_high / out.dof_high);
  out.p_value = FUpperTail(out.ratio, out.dof_low, out.dof_high);
  return out;
}

Eigen::Index LowBandSize(const Eigen::VectorXd& model, Eigen::Index q, double fraction) {
  const Eigen::Index n = model.size();
  const Eigen::Index lo = std::min<Eigen::Index>(4 * q, n / 2), hi = n / 2;
  double total = 0.0;  // sum of squared first differences = sum_k lambda_k a_k^2
  for (Eigen::Index j = 0; j + 1 < n; ++j) total += (model(j + 1) - model(j)) * (model(j + 1) - model(j));
  double sum = 0.0;
  DctBasisWalk phi(n);
  for (; phi.k() < hi; phi.Next()) {
    const double s = std::sin(kPi * static_cast<double>(phi.k()) / (2.0 * static_cast<double>(n)));
    const double a = phi.Coefficient(model);
    sum += 4.0 * s * s * a * a;
    if (sum >= fraction * total) break;
  }
  return std::clamp(phi.k() + 1, lo, hi);
}

// Notes on what the fit knows: missing samples, withheld standard errors, a
// residual above the noise. `handled`: what the method did with the gaps.
void AddVerdictWarnings(FitResult& out, const std::string& handled) {
  const GapCount& g = out.theta_gaps;
  if (g.missing_samples > 0) {
    out.warnings.push_back(std::to_string(g.missing_samples) + " theta sample(s) missing in " +
                           std::to_string(g.gaps) + " gap(s) (longest " + Num(g.longest_s, 3) +
                           " s between samples, first before line/event " + std::to_string(g.first_line) +
                           "): " + handled);
  }
  if (out.table_gaps.missing_samples > 0) {
    out.warnings.push_back(std::to_string(out.table_gaps.missing_samples) + " table sample(s) missing in " +
                           std::to_string(out.table_gaps.gaps) + " gap(s) (longest " +
                           Num(out.table_gaps.longest_s, 3) +
                           " s): the table acceleration is taken linear across them");
  }
  if (out.stderr_withheld) {
    out.warnings.push_back("standard errors withheld: " + std::to_string(out.residuals) + " residuals give " +
                           std::to_string(out.dof) + " degree(s) of freedom, fewer than " +
                           std::to_string(kMinDofForStderr));
  }
  const bool impacts = out.method == FitMethod::kImpacts;
  const double scale = impacts ? 1e3 : 1.0;
  const char* unit = impacts ? " ms" : " rad";
  if (out.p_value < ChiSquareLevel(out)) {
    out.warnings.push_back("not converged to the noise: residual / noise " + Num(out.residual_to_noise, 3) +
                           " (chi-square " + Num(out.chi2, 5) + " on " + std::to_string(out.dof) +
                           " degrees of freedom, p = " + Num(out.p_value, 2) + " below the level " +
                           Num(ChiSquareLevel(out), 2) + "; rms residual " +
                           Num(out.rms_residual * scale, 3) + unit + ", the noise alone gives " +
                           Num(out.noise_residual * scale, 3) + unit +
                           "): the model does not follow the record, or the fit stopped in a local minimum, "
                           "and the standard errors understate the error");
  } else if (!std::isfinite(out.noise_residual) && out.dof >= 1) {
    out.warnings.push_back("the record has no measurable noise: the residual (rms " +
                           Num(out.rms_residual * scale, 3) + unit + ") cannot be compared with it");
  }
}


}  // namespace fit_detail

using namespace fit_detail;

// --- public ------------------------------------------------------------------

const char* ToString(QuarterTime q) { return q == QuarterTime::kExact ? "exact" : "slender"; }
const char* ToString(FitMethod m) { return m == FitMethod::kImpacts ? "impacts" : "trajectory"; }

const char* TableReadingName(Interpolation i) {
  switch (i) {
    case Interpolation::kLinear: return "chord";
    case Interpolation::kCatmullRom: return "catmull-rom";
    case Interpolation::kSpline: return "spline";
  }
  return "spline";
}

Interpolation ParseTableReading(const std::string& name) {
  if (name == "spline") return Interpolation::kSpline;
  if (name == "chord") return Interpolation::kLinear;
  throw std::invalid_argument("table reading must be spline or chord, got '" + name + "'");
}

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

// Paulson's approximation: with a = 2 / (9 d1), b = 2 / (9 d2), the cube
// root of F is nearly normal, z = ((1 - b) F^(1/3) - (1 - a)) /
// sqrt(b F^(2/3) + a) (Abramowitz and Stegun 26.6.15).
double FUpperTail(double x, double d1, double d2) {
  if (!(d1 >= 1.0) || !(d2 > 0.0) || std::isnan(x)) return kNaN;
  if (!(x > 0.0)) return 1.0;
  if (std::isinf(x)) return 0.0;
  const double a = 2.0 / (9.0 * d1);
  const double b = std::isinf(d2) ? 0.0 : 2.0 / (9.0 * d2);
  const double c = std::cbrt(x);
  const double z = ((1.0 - b) * c - (1.0 - a)) / std::sqrt(b * c * c + a);
  return 0.5 * std::erfc(z / std::sqrt(2.0));
}

double QuarterTimeOf(QuarterTime kind, double alpha, double p, double r) {
  return kind == QuarterTime::kExact ? QuarterTimeExact(alpha, p, r) : QuarterTimeSlender(alpha, p, r);
}

AlphaBand AdmissibleAlphaBand(const FitGeometry& g, double band_m) {
  if (!(band_m >= 0.0) || !std::isfinite(band_m)) {
    throw std::invalid_argument("alpha band must be >= 0 m, got " + Num(band_m));
  }
  if (!g.polygon_m.empty()) {
    const BlockGeometry geometry = PolygonBlock(g.polygon_m);
    const double cx = geometry.centroid_m.x();
    const double half = geometry.plus.pivot_m.x() - cx;
    if (!(half - band_m > 0.0)) {
      throw std::invalid_argument("alpha band " + Num(band_m) + " m leaves no distance from the centroid to the +x pivot (" +
                                  Num(half) + " m)");
    }
    auto scaled = [&](double d) {
      std::vector<Eigen::Vector2d> v = g.polygon_m;
      for (auto& x : v) x.x() = cx + (x.x() - cx) * (half + d) / half;
      return PolygonBlock(v).alpha;
    };
    AlphaBand b;
    b.band_m = band_m;
    b.geometric = geometry.alpha;
    b.lo = scaled(-band_m);
    b.hi = scaled(+band_m);
    return b;
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
  if (!(features.noise_rad >= 0.0) || !std::isfinite(features.noise_rad)) bad("noise must be >= 0 rad (0: estimated)");
  if (!(significance > 0.0 && significance < 0.5)) bad("significance must be in (0, 0.5), got " + Num(significance));
  if (starts < -1 || starts > 10000) bad("starts must be -1 (default) .. 10000, got " + std::to_string(starts));
  if (start) start->Validate();
}

}  // namespace rocklab::model
