#include "video/plane_map.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace rocklab::video {
namespace {

// Plausibility bounds (PlaneMap::CheckPlausible).
constexpr double kMaxScaleRatio = 20.0;
constexpr double kMaxMarkOffFraction = 0.05;

cv::Point2d Apply(const cv::Matx33d& h, const cv::Point2d& p) {
  const cv::Vec3d q = h * cv::Vec3d(p.x, p.y, 1.0);
  return {q[0] / q[2], q[1] / q[2]};
}

}  // namespace

PlaneMap::PlaneMap(const std::optional<Intrinsics>& intrinsics, const std::vector<Mark>& marks,
                   const std::string& rig_path) {
  if (intrinsics) {
    k_ = cv::Matx33d(intrinsics->fx_px, 0, intrinsics->cx_px, 0, intrinsics->fy_px, intrinsics->cy_px, 0, 0, 1);
    dist_ = cv::Mat(1, 5, CV_64F);
    for (int i = 0; i < 5; ++i) {
      dist_.at<double>(i) = intrinsics->distortion[static_cast<std::size_t>(i)];
      distorted_ = distorted_ || intrinsics->distortion[static_cast<std::size_t>(i)] != 0;
    }
  }
  if (marks.size() < 4) throw std::runtime_error(rig_path + ": fewer than 4 reference marks");
  std::vector<cv::Point2d> image, plane;
  for (const Mark& m : marks) {
    image.emplace_back(m.u_px, m.v_px);
    plane.emplace_back(m.x_m, m.z_m);
  }
  Undistort(image, undistorted_);
  const std::vector<cv::Point2d> image_ideal = undistorted_;
  const cv::Mat h = cv::findHomography(image_ideal, plane, 0);
  if (h.empty() || !cv::checkRange(h)) {
    throw std::runtime_error(rig_path + ":" + std::to_string(marks.front().line) +
                             ": key 'camera.video.mark': the marks do not determine a homography "
                             "(need 4 or more, no 3 of them on a line)");
  }
  h_ = cv::Matx33d(h.ptr<double>());
  const cv::Matx33d inv = h_.inv();
  double sm = 0, sp = 0;
  for (std::size_t i = 0; i < marks.size(); ++i) {
    const cv::Point2d p = Apply(h_, image_ideal[i]);
    sm += std::pow(p.x - plane[i].x, 2) + std::pow(p.y - plane[i].y, 2);
    const cv::Point2d q = Apply(inv, plane[i]);
    sp += std::pow(q.x - image_ideal[i].x, 2) + std::pow(q.y - image_ideal[i].y, 2);
  }
  mark_rms_m_ = std::sqrt(sm / static_cast<double>(marks.size()));
  mark_rms_px_ = std::sqrt(sp / static_cast<double>(marks.size()));
  // Scale at the marks' centre: the plane distance of a one-pixel step.
  cv::Point2d c(0, 0);
  for (const cv::Point2d& p : image_ideal) c += p;
  c *= 1.0 / static_cast<double>(image_ideal.size());
  const cv::Point2d a = Apply(h_, c), b = Apply(h_, c + cv::Point2d(1, 0)), d = Apply(h_, c + cv::Point2d(0, 1));
  scale_m_per_px_ = 0.5 * (std::hypot(b.x - a.x, b.y - a.y) + std::hypot(d.x - a.x, d.y - a.y));
  CheckPlausible(marks, image_ideal, plane, rig_path);
}

// A plane seen through a lens maps to the image without folding (the
// homography's w = h3 . (u, v, 1) keeps its sign where the plane is seen),
// with a finite, non-zero scale that changes by a bounded factor across the
// marks (a plane seen more obliquely than ~87 degrees is not measured), and
// through every mark (a mark off the others' homography by a few % of their
// spread was typed wrong or swapped). Anything else is refused: the
// numbers it would give are not lengths.
void PlaneMap::CheckPlausible(const std::vector<Mark>& marks, const std::vector<cv::Point2d>& image_ideal,
                              const std::vector<cv::Point2d>& plane, const std::string& rig_path) const {
  const std::string where = rig_path + ":" + std::to_string(marks.front().line) + ": key 'camera.video.mark': ";
  const auto w_of = [this](const cv::Point2d& p) { return h_(2, 0) * p.x + h_(2, 1) * p.y + h_(2, 2); };
  // The points looked at: the marks and the corners of their box.
  double u0 = image_ideal[0].x, u1 = u0, v0 = image_ideal[0].y, v1 = v0;
  for (const cv::Point2d& p : image_ideal) {
    u0 = std::min(u0, p.x), u1 = std::max(u1, p.x), v0 = std::min(v0, p.y), v1 = std::max(v1, p.y);
  }
  std::vector<cv::Point2d> points = image_ideal;
  points.insert(points.end(), {{u0, v0}, {u1, v0}, {u0, v1}, {u1, v1}});
  const double w0 = w_of(points.front());
  double smallest = std::numeric_limits<double>::infinity(), largest = 0;
  for (const cv::Point2d& p : points) {
    if (!(w_of(p) * w0 > 0)) {
      throw std::runtime_error(where + "the marks fold the plane (its horizon runs between them): are two marks "
                               "swapped, or a mark's x_m and z_m?");
    }
    // The Jacobian's singular values: metres per pixel along the plane's
    // most and least stretched directions at p.
    const cv::Point2d q = Apply(h_, p), du = Apply(h_, p + cv::Point2d(1, 0)) - q,
                      dv = Apply(h_, p + cv::Point2d(0, 1)) - q;
    const double e = 0.5 * (du.dot(du) + dv.dot(dv));
    const double det = std::abs(du.x * dv.y - du.y * dv.x);
    const double root = std::sqrt(std::max(0.0, e * e - det * det));
    const double s_max = std::sqrt(e + root), s_min = det / std::max(s_max, 1e-300);
    if (!std::isfinite(s_max) || !(s_min > 0)) {
      throw std::runtime_error(where + "the marks give no finite scale (inf mm/px or 0): are two marks swapped?");
    }
    smallest = std::min(smallest, s_min);
    largest = std::max(largest, s_max);
  }
  if (largest > kMaxScaleRatio * smallest) {
    char msg[200];
    std::snprintf(msg, sizeof msg,
                  "the scale changes from %.3g to %.3g mm/px across the marks (more than %gx: a plane seen more "
                  "obliquely than a camera measures): are two marks swapped?",
                  1e3 * smallest, 1e3 * largest, kMaxScaleRatio);
    throw std::runtime_error(where + msg);
  }
  // Every mark on the homography, within a fraction of the marks' spread.
  cv::Point2d centre(0, 0);
  for (const cv::Point2d& p : plane) centre += p;
  centre *= 1.0 / static_cast<double>(plane.size());
  double spread2 = 0;
  for (const cv::Point2d& p : plane) spread2 += (p - centre).dot(p - centre);
  const double spread = std::sqrt(spread2 / static_cast<double>(plane.size()));
  std::size_t worst = 0;
  double worst_m = 0;
  for (std::size_t i = 0; i < marks.size(); ++i) {
    const cv::Point2d d = Apply(h_, image_ideal[i]) - plane[i];
    if (std::hypot(d.x, d.y) > worst_m) worst_m = std::hypot(d.x, d.y), worst = i;
  }
  if (worst_m > kMaxMarkOffFraction * spread) {
    char msg[240];
    std::snprintf(msg, sizeof msg,
                  ": key 'camera.video.mark': this mark is %.3g mm off the homography of all the marks (more than "
                  "%g %% of their %.3g mm spread): a typo, or two marks swapped?",
                  1e3 * worst_m, 100 * kMaxMarkOffFraction, 1e3 * spread);
    throw std::runtime_error(rig_path + ":" + std::to_string(marks[worst].line) + msg);
  }
}

void PlaneMap::Undistort(const std::vector<cv::Point2d>& in, std::vector<cv::Point2d>& out) const {
  if (!distorted_ || in.empty()) {
    out = in;
    return;
  }
  // 20 iterations of OpenCV's fixed-point inverse: below 1e-4 px for the
  // distortions of machine-vision lenses (its default 5 leaves ~1e-2 px).
  cv::undistortPoints(in, out, k_, dist_, cv::noArray(), k_,
                      cv::TermCriteria(cv::TermCriteria::COUNT, 20, 0));
}

void PlaneMap::ToPlane(const std::vector<cv::Point2d>& image_px, std::vector<cv::Point2d>& xz_m) const {
  Undistort(image_px, undistorted_);
  xz_m.resize(undistorted_.size());
  for (std::size_t i = 0; i < undistorted_.size(); ++i) xz_m[i] = Apply(h_, undistorted_[i]);
}

}  // namespace rocklab::video
