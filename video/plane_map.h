#pragma once
/// @file
/// Image to rig plane: a centroid is undistorted with the lens intrinsics
/// (OpenCV's iterative inverse of its distortion model, back to pixels of
/// the ideal pinhole), then mapped by the homography that takes the
/// undistorted reference marks to their rig coordinates (x, z), m. A plane
/// seen through a pinhole is exactly a homography, so with the right
/// intrinsics nothing is approximated beyond the marks' own errors.

#include <vector>

#include <opencv2/core.hpp>

#include "video/video_config.h"

namespace rocklab::video {

class PlaneMap {
 public:
  /// @throws std::runtime_error naming the rig file when the marks do not
  ///         determine a homography (fewer than 4, or 3 on a line), or one
  ///         that is not a camera's view of a plane: folded between the
  ///         marks, an infinite or zero scale, a scale changing by more than
  ///         20x across them, or a mark off it by more than 5 % of their
  ///         spread (naming that mark's line).
  PlaneMap(const std::optional<Intrinsics>& intrinsics, const std::vector<Mark>& marks,
           const std::string& rig_path);
  /// Maps image points (px) to the plane (m), in place of `xz` (resized). Never throws.
  void ToPlane(const std::vector<cv::Point2d>& image_px, std::vector<cv::Point2d>& xz_m) const;
  /// RMS distance of the marks from their rig coordinates after the mapping, m
  /// (0 with exactly 4 marks: the homography passes through them).
  double mark_rms_m() const { return mark_rms_m_; }
  /// The same residual seen in the image, px (the mapping's inverse).
  double mark_rms_px() const { return mark_rms_px_; }
  /// Metres per pixel at the marks' centre (for figures and gates).
  double scale_m_per_px() const { return scale_m_per_px_; }

 private:
  void Undistort(const std::vector<cv::Point2d>& in, std::vector<cv::Point2d>& out) const;
  void CheckPlausible(const std::vector<Mark>& marks, const std::vector<cv::Point2d>& image_ideal,
                      const std::vector<cv::Point2d>& plane, const std::string& rig_path) const;
  bool distorted_{false};
  cv::Matx33d k_;
  cv::Mat dist_;
  cv::Matx33d h_;
  double mark_rms_m_{}, mark_rms_px_{}, scale_m_per_px_{};
  mutable std::vector<cv::Point2d> undistorted_;  // reused
};

}  // namespace rocklab::video
