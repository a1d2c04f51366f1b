#include "model/block.h"

#include "model/numbers.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

namespace rocklab::model {
namespace {

using detail::ExactText;
using detail::kPi;

[[noreturn]] void Bad(const std::string& what, const std::string& rule, double value) {
  throw std::invalid_argument(what + " must be " + rule + " (got " + ExactText(value) + ")");
}

}  // namespace

void BlockParams::Validate() const {
  if (!std::isfinite(alpha) || alpha <= 0.0 || alpha >= kPi / 2) Bad("alpha", "in (0, pi/2) rad", alpha);
  if (!std::isfinite(p) || p <= 0.0) Bad("p", "finite and > 0 rad/s", p);
  if (!std::isfinite(mu) || mu <= 0.0 || mu > 1.0) Bad("mu", "in (0, 1]", mu);
}

BlockGeometry RectangleBlock(double width_m, double height_m, double chamfer_m, double g) {
  if (!std::isfinite(width_m) || width_m <= 0.0) Bad("width_m", "finite and > 0 m", width_m);
  if (!std::isfinite(height_m) || height_m <= 0.0) Bad("height_m", "finite and > 0 m", height_m);
  const double b = width_m / 2;
  const double h = height_m / 2;
  if (!std::isfinite(chamfer_m) || chamfer_m < 0.0 || chamfer_m >= std::min(b, h)) {
    Bad("chamfer_m", "in [0, min(b, h)) m", chamfer_m);
  }
  if (!std::isfinite(g) || g <= 0.0) Bad("g", "finite and > 0 m/s^2", g);
  // Base on y = 0, symmetric about x = 0, counter-clockwise.
  std::vector<Eigen::Vector2d> v;
  if (chamfer_m > 0.0) {
    const double c = chamfer_m;
    v = {{-b + c, 0.0}, {b - c, 0.0}, {b, c}, {b, 2 * h}, {-b, 2 * h}, {-b, c}};
  } else {
    v = {{-b, 0.0}, {b, 0.0}, {b, 2 * h}, {-b, 2 * h}};
  }
  return PolygonBlock(v, g);
}

BlockGeometry PolygonBlock(const std::vector<Eigen::Vector2d>& vertices_m, double g) {
  const std::size_t n = vertices_m.size();
  if (n < 3) {
    throw std::invalid_argument("vertices_m must hold at least 3 vertices (got " +
                                std::to_string(n) + ")");
  }
  if (!std::isfinite(g) || g <= 0.0) Bad("g", "finite and > 0 m/s^2", g);
  double scale = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!vertices_m[i].allFinite()) {
      throw std::invalid_argument("vertices_m[" + std::to_string(i) + "] is not finite");
    }
    scale = std::max(scale, vertices_m[i].cwiseAbs().maxCoeff());
  }
  // Pivot: the lowest vertex, and among the lowest the one with the largest x.
  double y_min = vertices_m[0].y();
  for (const auto& v : vertices_m) y_min = std::min(y_min, v.y());
  const double tie = 1e-12 * std::max(scale, 1.0);
  Eigen::Vector2d pivot(-HUGE_VAL, y_min);
  for (const auto& v : vertices_m) {
    if (v.y() <= y_min + tie && v.x() > pivot.x()) pivot = v;
  }
  // Shoelace sums with the pivot as origin: area, first and polar second
  // moments of area.
  double a2 = 0.0;   // 2 * signed area
  double sx6 = 0.0;  // 6 * signed first moment about the y axis (x centroid * area)
  double sy6 = 0.0;
  double j12 = 0.0;  // 12 * signed polar moment about the pivot
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d p0 = vertices_m[i] - pivot;
    const Eigen::Vector2d p1 = vertices_m[(i + 1) % n] - pivot;
    const double cross = p0.x() * p1.y() - p1.x() * p0.y();
    a2 += cross;
    sx6 += (p0.x() + p1.x()) * cross;
    sy6 += (p0.y() + p1.y()) * cross;
    j12 += cross * (p0.x() * p0.x() + p0.x() * p1.x() + p1.x() * p1.x() + p0.y() * p0.y() +
                    p0.y() * p1.y() + p1.y() * p1.y());
  }
  const double area = std::abs(a2) / 2;
  if (!(area > 1e-12 * scale * scale)) {
    throw std::invalid_argument("vertices_m: polygon has zero area");
  }
  const double cx = sx6 / (3 * a2);  // relative to the pivot
  const double cy = sy6 / (3 * a2);
  const double i_o_per_area = (j12 / 12) / (a2 / 2);
  if (!(cy > 0.0)) throw std::invalid_argument("vertices_m: centroid is not above the base");
  if (!(cx < 0.0)) {
    throw std::invalid_argument("vertices_m: centroid is not inside the pivot (x of centroid >= x of pivot)");
  }
  BlockGeometry out;
  out.area = area;
  out.R = std::hypot(cx, cy);
  out.alpha = std::atan2(-cx, cy);
  out.i_o_per_area = i_o_per_area;
  out.p = std::sqrt(g * out.R / i_o_per_area);
  const double s = std::sin(out.alpha);
  out.mu_housner = 1.0 - 1.5 * s * s;
  out.mu_general = 1.0 - 2.0 * out.R * out.R / i_o_per_area * s * s;
  return out;
}

}  // namespace rocklab::model
