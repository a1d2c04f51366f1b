#include "video/plane_map.h"

#include <cmath>
#include <stdexcept>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace rocklab::video {
namespace {

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
