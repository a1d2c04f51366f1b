// The fit's number helpers and the Levenberg-Marquardt covariance
// (model/fit_impl.h declares them).
#include <algorithm>
#include <cmath>
#include <numeric>
#include <sstream>

#include "model/fit_impl.h"

namespace rocklab::model::fit_detail {

std::string Num(double v, int digits) {
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

double LocalNoiseScale(double rss, int dof, double noise) {
  if (dof < 1 || !(rss >= 0.0)) return noise;
  // 1 % upper quantile of chi2(dof) by the Wilson-Hilferty cube root.
  const double k = dof;
  const double q = k * std::pow(1.0 - 2.0 / (9.0 * k) + 2.3263 * std::sqrt(2.0 / (9.0 * k)), 3);
  return rss > q * noise * noise ? std::sqrt(rss / k) : noise;
}

// Index range [lo, hi) of the samples with time in [t0, t1].
std::pair<std::size_t, std::size_t> Range(const std::vector<double>& t, double t0, double t1) {
  const auto lo = std::lower_bound(t.begin(), t.end(), t0) - t.begin();
  const auto hi = std::upper_bound(t.begin(), t.end(), t1) - t.begin();
  return {static_cast<std::size_t>(lo), static_cast<std::size_t>(hi)};
}

double StdDev(const std::vector<double>& v) {
  if (v.size() < 2) return kNaN;
  const double mean = std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
  double s = 0.0;
  for (double x : v) s += (x - mean) * (x - mean);
  return std::sqrt(s / static_cast<double>(v.size() - 1));
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

}  // namespace rocklab::model::fit_detail
