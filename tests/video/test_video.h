#pragma once
// The video tests' own truth: a camera model (pinhole, Brown radial
// distortion, a yaw), LED spots and chessboards rendered through it, and a
// writer (FFmpeg's libraries directly, not OpenCV, not rocklab) that puts
// each frame at a timestamp of the test's choosing, so a dropped frame is a
// real gap in the container's times.

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace rocklab::test {

/// A camera looking at the rig plane (x right, z up; the plane y = 0) from
/// y = -distance_m, turned by yaw_rad about the vertical, centred at (x0, z0).
struct TestCamera {
  double fx{300}, fy{300}, cx{160}, cy{120};
  double k1{0}, k2{0};  // radial distortion (OpenCV's k1, k2; p1 = p2 = k3 = 0)
  double distance_m{0.75}, yaw_rad{0}, x0_m{0}, z0_m{0.35};
  int width{320}, height{240};

  // Normalised ideal coordinates to distorted pixels.
  cv::Point2d Distort(double a, double b) const {
    const double r2 = a * a + b * b;
    const double f = 1 + k1 * r2 + k2 * r2 * r2;
    return {fx * a * f + cx, fy * b * f + cy};
  }
  // Distorted pixel to normalised ideal coordinates (fixed point, 30 steps).
  cv::Point2d Undistort(double u, double v) const {
    const double ad = (u - cx) / fx, bd = (v - cy) / fy;
    double a = ad, b = bd;
    for (int i = 0; i < 30; ++i) {
      const double r2 = a * a + b * b;
      const double f = 1 + k1 * r2 + k2 * r2 * r2;
      a = ad / f;
      b = bd / f;
    }
    return {a, b};
  }
  // A point of the rig plane to pixels.
  cv::Point2d Project(double x, double z) const {
    const double X = x - x0_m, Y = distance_m, Z = z - z0_m;
    const double c = std::cos(yaw_rad), s = std::sin(yaw_rad);
    const double xc = c * X + s * Y, yc = -s * X + c * Y;  // yc: depth
    return Distort(xc / yc, -Z / yc);
  }
};

/// Writes 8-bit grey frames into a Matroska file: FFV1 (lossless) or MJPEG
/// (lossy, quantiser `mjpeg_q`, 2 = fine .. 31 = coarse), each frame at
/// its own presentation time (ms).
class TestVideoWriter {
 public:
  TestVideoWriter(const std::string& path, bool lossless, int width, int height, int fps, int mjpeg_q = 3);
  ~TestVideoWriter();
  TestVideoWriter(const TestVideoWriter&) = delete;
  TestVideoWriter& operator=(const TestVideoWriter&) = delete;
  void Write(const cv::Mat& gray, int64_t pts_ms);
  void Close();

 private:
  struct Impl;
  Impl* impl_;
};

}  // namespace rocklab::test
