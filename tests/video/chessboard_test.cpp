// A chessboard filmed by the test's own distorting camera (test_video.h)
// in 20 poses, written lossless, calibrated by rocklab's camera-calibrate
// library (OpenCV's calibration behind it).
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <cstdio>
#include <random>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>

#include "tests/scratch.h"
#include "tests/sha256sum.h"
#include "tests/video/test_video.h"
#include "video/camera_calibration.h"
#include "video/video_config.h"

namespace rocklab::video {
namespace {

constexpr int kCols = 9, kRows = 6;   // inner corners
constexpr double kSquareM = 0.02;
constexpr int kViews = 20;
constexpr int kSuper = 3;             // samples per pixel side (anti-aliasing)

// The board's grey level seen along the ray of pixel sample (u, v), for a
// board at rotation (rx, ry) about its centre and distance d: the ray's
// intersection with the board plane, its square's colour.
double Shade(const test::TestCamera& cam, double u, double v, const cv::Matx33d& r, const cv::Vec3d& t) {
  const cv::Point2d ab = cam.Undistort(u, v);
  const cv::Vec3d d(ab.x, ab.y, 1.0);
  // s d = R (X, Y, 0) + t  ->  [R0 R1 -d] (X, Y, s) = -t
  const cv::Matx33d m(r(0, 0), r(0, 1), -d[0], r(1, 0), r(1, 1), -d[1], r(2, 0), r(2, 1), -d[2]);
  const cv::Vec3d x = m.solve(-t, cv::DECOMP_LU);
  if (x[2] <= 0) return 128;
  // Board: (kCols + 1) x (kRows + 1) squares, a white border of one square.
  const double sx = x[0] / kSquareM + 1, sy = x[1] / kSquareM + 1;  // the first inner corner at (0, 0)
  if (sx < -1 || sy < -1 || sx >= kCols + 2 || sy >= kRows + 2) return 128;
  if (sx < 0 || sy < 0 || sx >= kCols + 1 || sy >= kRows + 1) return 220;
  const int i = static_cast<int>(std::floor(sx)), j = static_cast<int>(std::floor(sy));
  return ((i + j) % 2 == 0) ? 30 : 220;
}

TEST(CameraCalibrate, RecoversTheRenderingCamerasIntrinsics) {
  test::TestCamera cam;
  cam.fx = 310;
  cam.fy = 305;
  cam.cx = 163;
  cam.cy = 118;
  cam.k1 = -0.2;
  cam.k2 = 0.05;
  const std::string dir = test::ScratchDir("chessboard");
  const std::string path = dir + "/board.mkv";
  double reach_r2 = 0;
  {
    test::TestVideoWriter w(path, true, cam.width, cam.height, 10);
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> tilt(-0.45, 0.45), shift(-0.03, 0.03), dist(0.33, 0.42);
    std::normal_distribution<double> noise(0.0, 1.0);
    for (int k = 0; k < kViews; ++k) {
      // One draw per statement: the order of a call's arguments is the
      // compiler's (gcc and clang differ), the poses must not be.
      const double rx = tilt(rng), ry = tilt(rng), rz = 0.3 * tilt(rng);
      const double shift_x = shift(rng), shift_y = shift(rng), d = dist(rng);
      cv::Vec3d rvec(rx, ry, rz);
      cv::Matx33d r;
      cv::Rodrigues(rvec, r);
      // Board centre on the optical axis (shifted a little), at distance d.
      const cv::Vec3d centre_board(0.5 * (kCols - 1) * kSquareM, 0.5 * (kRows - 1) * kSquareM, 0);
      const cv::Vec3d t = cv::Vec3d(shift_x, shift_y, d) - r * centre_board;
      for (int j = 0; j < kRows; ++j) {  // how far out the corners reach (ideal normalised radius^2)
        for (int i = 0; i < kCols; ++i) {
          const cv::Vec3d p = r * cv::Vec3d(i * kSquareM, j * kSquareM, 0) + t;
          reach_r2 = std::max(reach_r2, (p[0] * p[0] + p[1] * p[1]) / (p[2] * p[2]));
        }
      }
      cv::Mat img(cam.height, cam.width, CV_8U);
      for (int y = 0; y < cam.height; ++y) {
        for (int x = 0; x < cam.width; ++x) {
          double sum = 0;
          for (int sy = 0; sy < kSuper; ++sy) {
            for (int sx = 0; sx < kSuper; ++sx) {
              sum += Shade(cam, x + (sx + 0.5) / kSuper - 0.5, y + (sy + 0.5) / kSuper - 0.5, r, t);
            }
          }
          img.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(std::lround(sum / (kSuper * kSuper) + noise(rng)));
        }
      }
      w.Write(img, k * 100);
    }
    w.Close();
  }
  ChessboardOptions o;
  o.cols = kCols;
  o.rows = kRows;
  o.square_m = kSquareM;
  const CalibrationResult r = CalibrateFromVideo(path, o);
  const Intrinsics& k = r.intrinsics;
  std::printf("board in %d of %d frames; fx %.3f fy %.3f cx %.3f cy %.3f k1 %.4f k2 %.4f p1 %.5f p2 %.5f; "
              "RMS %.4f px, worst view %.4f px; corners reach radius %.3f (normalised)\n",
              r.boards_found, r.frames_read, k.fx_px, k.fy_px, k.cx_px, k.cy_px, k.distortion[0], k.distortion[1],
              k.distortion[2], k.distortion[3], k.rms_reprojection_px, r.worst_view_rms_px, std::sqrt(reach_r2));
  // Oracle: the rendering camera. Corners of an anti-aliased board with
  // 1-level noise are found to about 0.05 px; 20 views of 54 corners
  // determine the focal lengths to well below 1% and the centre to about
  // a pixel. Stated bounds: fx, fy within 1%, cx, cy within 2 px, the
  // reprojection RMS below 0.2 px, and the distortion's radial displacement
  // at the farthest radius the board's corners reach (beyond it the fit
  // extrapolates: k1 and k2 trade against each other) within 0.5 px.
  EXPECT_GE(r.boards_found, kViews - 2);
  EXPECT_NEAR(k.fx_px, cam.fx, 0.01 * cam.fx);
  EXPECT_NEAR(k.fy_px, cam.fy, 0.01 * cam.fy);
  EXPECT_NEAR(k.cx_px, cam.cx, 2.0);
  EXPECT_NEAR(k.cy_px, cam.cy, 2.0);
  EXPECT_LT(k.rms_reprojection_px, 0.2);
  const double r2 = reach_r2;
  const double truth_px = cam.fx * std::sqrt(r2) * (cam.k1 * r2 + cam.k2 * r2 * r2);
  const double got_px = k.fx_px * std::sqrt(r2) * (k.distortion[0] * r2 + k.distortion[1] * r2 * r2);
  EXPECT_NEAR(got_px, truth_px, 0.5);
  // The file `rocklab camera-calibrate` writes reads back the same.
  WriteIntrinsics(dir + "/cam.toml", k, "test");
  const Intrinsics back = LoadIntrinsics(dir + "/cam.toml");
  EXPECT_NEAR(back.fx_px, k.fx_px, 1e-6 * k.fx_px);
  EXPECT_NEAR(back.distortion[0], k.distortion[0], 1e-8);
  EXPECT_EQ(back.views, k.views);
  // The command: the same calibration, its file, its report (on stderr
  // with --json, whose object is on stdout).
  const std::string cmd = std::string(ROCKLAB_BINARY) + " camera-calibrate " + path + " --board 9x6 --square " +
                          std::to_string(kSquareM) + " --out " + dir + "/cli.toml --json > " + dir + "/cli.json 2> " +
                          dir + "/cli.out";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  const Intrinsics cli = LoadIntrinsics(dir + "/cli.toml");
  EXPECT_NEAR(cli.fx_px, k.fx_px, 1e-6 * k.fx_px);
  EXPECT_NEAR(cli.rms_reprojection_px, k.rms_reprojection_px, 1e-5);
  std::ifstream out(dir + "/cli.out");
  const std::string text((std::istreambuf_iterator<char>(out)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("reprojection error: RMS"), std::string::npos) << text;
  std::ifstream json_in(dir + "/cli.json");
  const nlohmann::json j = nlohmann::json::parse(json_in);
  EXPECT_NEAR(j.at("fx_px").get<double>(), cli.fx_px, 1e-6 * cli.fx_px);
  EXPECT_NEAR(j.at("distortion").at(0).get<double>(), cli.distortion[0], 1e-6);
  EXPECT_NEAR(j.at("rms_reprojection_px").get<double>(), cli.rms_reprojection_px, 1e-5);
  EXPECT_EQ(j.at("views").get<int>(), cli.views);
  // What made the file, as TOML comments (docs/provenance.md): the video
  // with its size and SHA-256 (oracle: coreutils' sha256sum).
  std::ifstream toml_in(dir + "/cli.toml");
  const std::string toml((std::istreambuf_iterator<char>(toml_in)), std::istreambuf_iterator<char>());
  const std::string video_hash = test::Sha256sum(path);
  ASSERT_EQ(video_hash.size(), 64u);
  EXPECT_NE(toml.find("\n# provenance.source_1: " + path + " (" + std::to_string(std::filesystem::file_size(path)) +
                      " bytes, sha256 " + video_hash + ")\n"),
            std::string::npos)
      << toml;
  EXPECT_NE(toml.find("\n# provenance.command: " + std::string(ROCKLAB_BINARY) + " camera-calibrate " + path), std::string::npos)
      << toml;
  // A board size the video does not hold: an error naming the video, exit 2.
  const std::string bad = std::string(ROCKLAB_BINARY) + " camera-calibrate " + path + " --board 7x5 --out " + dir +
                          "/bad.toml > " + dir + "/bad.out 2>&1";
  EXPECT_EQ(WEXITSTATUS(std::system(bad.c_str())), 2);
  EXPECT_FALSE(std::filesystem::exists(dir + "/bad.toml"));
}

}  // namespace
}  // namespace rocklab::video
