#pragma once
// The video tests' own truth: a camera model (pinhole, Brown radial
// distortion, a yaw), LED spots and chessboards rendered through it, and a
// writer (FFmpeg's libraries directly, not OpenCV, not rocklab) that puts
// each frame at a timestamp of the test's choosing, so a dropped frame is a
// real gap in the container's times.

#include <array>
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

/// An LED of a test rig: its name and block-frame place, m.
struct RigLed {
  std::string name;
  double x_m, z_m;
};

/// A rig file for a 0.25 x 1.0 m block filmed by one camera "side" with
/// these LEDs (channels side_<led>_x|z, gain 1: metres), its
/// [camera.video] section holding `video_keys` (TOML lines) and reference
/// marks at the plane points `marks` (x, z; m) where `cam` projects them.
std::string VideoRigText(const TestCamera& cam, double sample_rate_hz, const std::vector<RigLed>& leds,
                         const std::string& video_keys, const std::vector<std::array<double, 2>>& marks);

/// The error opening `input` (empty: a missing video in the scratch
/// folder `name`) with the rig `rig_text` written there gives; "" if it opens.
std::string VideoOpenError(const std::string& name, const std::string& rig_text, const std::string& input);

/// Standard deviation of the detector's centroid along one axis, px, for a
/// Gaussian spot (sigma `spot_sigma_px`, `peak` levels over `background`)
/// under white pixel noise `pixel_sigma` (levels). Oracle: the
/// intensity-weighted centroid over a box of N pixels has standard
/// deviation sigma * sqrt(sum (x - u)^2) / sum(w); the box is the blob's
/// above-threshold extent (radius r where the spot falls to the threshold)
/// widened by the margin; sum(w) = 2 pi s^2 peak; 8-bit quantisation adds
/// 1/12 level^2 to sigma^2.
inline double CentroidSigmaPx(double spot_sigma_px, double peak, double threshold, double background, int margin_px,
                              double pixel_sigma) {
  const double r = spot_sigma_px * std::sqrt(2 * std::log(peak / (threshold - background)));
  const int h = static_cast<int>(std::ceil(r)) + margin_px;
  double sum_x2 = 0;
  for (int i = -h; i <= h; ++i) sum_x2 += (2 * h + 1) * i * i;
  const double sum_w = 2 * M_PI * spot_sigma_px * spot_sigma_px * peak;
  return std::sqrt(pixel_sigma * pixel_sigma + 1.0 / 12) * std::sqrt(sum_x2) / sum_w;
}

/// `light` (CV_64F, levels) as a sensor gives it: white noise of `sigma`
/// levels added, rounded and clipped to 8 bits (its ADC).
inline cv::Mat SensorFrame(const cv::Mat& light, double sigma, cv::RNG& rng) {
  cv::Mat noise(light.rows, light.cols, CV_64F);
  rng.fill(noise, cv::RNG::NORMAL, 0.0, sigma);
  cv::Mat out;
  cv::Mat signal = light + noise;
  signal.convertTo(out, CV_8U);
  return out;
}

/// Writes 8-bit grey frames into a Matroska file (an AVI one when `path`
/// ends in ".avi": frames on the 1 / fps grid, its index at the end): FFV1
/// (lossless) or MJPEG (lossy, quantiser `mjpeg_q`, 2 = fine .. 31 =
/// coarse), each frame at its own presentation time (ms). An MJPEG file's
/// frames may change size midway (the stream's header keeps the first
/// size). Or H.264 (H264()), or colour MJPEG (Colour()).
class TestVideoWriter {
 public:
  TestVideoWriter(const std::string& path, bool lossless, int width, int height, int fps, int mjpeg_q = 3);
  /// MJPEG of 8-bit BGR frames (CV_8UC3), 4:4:4 (no chroma subsampling): the
  /// writer's own BT.601 full-range conversion, Y = 0.299 R + 0.587 G +
  /// 0.114 B, Cb = 128 + 0.564 (B - Y), Cr = 128 + 0.713 (R - Y), as JPEG's.
  static TestVideoWriter Colour(const std::string& path, int width, int height, int fps, int mjpeg_q);
  /// H.264 (libx264, constant quality `crf`) with up to `b_frames` B-frames
  /// between references: frames decoded out of order, the decoder holding
  /// the last ones until it is flushed.
  static TestVideoWriter H264(const std::string& path, int width, int height, int fps, int crf, int b_frames);
  TestVideoWriter(TestVideoWriter&& other) noexcept : impl_(other.impl_) { other.impl_ = nullptr; }
  ~TestVideoWriter();
  TestVideoWriter(const TestVideoWriter&) = delete;
  TestVideoWriter& operator=(const TestVideoWriter&) = delete;
  void Write(const cv::Mat& gray, int64_t pts_ms);
  void Close();

 private:
  struct Impl;
  explicit TestVideoWriter(Impl* impl) : impl_(impl) {}
  Impl* impl_;
};

}  // namespace rocklab::test
