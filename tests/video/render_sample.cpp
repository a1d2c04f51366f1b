// rocklab_render_video: the bundled video sample (data/README.md, "The
// video sample") rendered by the tests' own camera (test_video.h): a
// block rocking as a theta(t) CSV says (`rocklab synth --truth`), four
// LEDs on its face drawn as Gaussian spots through the camera, averaged
// over the exposure, with sensor noise and 8-bit quantisation, written as
// MJPEG in Matroska with each frame at its own time. It also writes the
// rig whose [camera.video] marks are where this camera sees them.
//
//   rocklab_render_video TRUTH.csv VIDEO.mkv RIG.toml [FPS] [DURATION_S]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "tests/video/test_video.h"

namespace {

constexpr double kSampleHalfWidthM = 0.1235;  // block 1: 0.247 x 1.0 m
constexpr double kSampleSpotPx = 1.3;
constexpr double kSamplePeak = 190;
constexpr double kSampleBackground = 10;
constexpr double kSampleNoise = 1.0;    // levels
constexpr double kSampleExposureS = 0.002;
constexpr int kSampleBlurSteps = 4;
constexpr int kSampleMjpegQ = 4;

struct SampleLed {
  const char* name;
  double x, z;
};
const SampleLed kSampleLeds[] = {{"A", -0.08, 0.15}, {"B", 0.08, 0.15}, {"C", -0.08, 0.55}, {"D", 0.08, 0.55}};

// theta(t) from a CSV with `time` and `theta` columns, linearly interpolated.
struct ThetaTrack {
  std::vector<double> t, theta;
  double At(double time) const {
    if (time <= t.front()) return theta.front();
    if (time >= t.back()) return theta.back();
    const std::size_t i = static_cast<std::size_t>(std::upper_bound(t.begin(), t.end(), time) - t.begin());
    const double f = (time - t[i - 1]) / (t[i] - t[i - 1]);
    return theta[i - 1] + f * (theta[i] - theta[i - 1]);
  }
};

ThetaTrack ReadTruth(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot be read");
  std::string line;
  std::getline(in, line);
  std::vector<std::string> head;
  std::stringstream hs(line);
  for (std::string c; std::getline(hs, c, ',');) head.push_back(c);
  const auto col = [&](const char* name) {
    const auto it = std::find(head.begin(), head.end(), name);
    if (it == head.end()) throw std::runtime_error(path + ": no column '" + name + "'");
    return static_cast<std::size_t>(it - head.begin());
  };
  const std::size_t ct = col("time"), cth = col("theta");
  ThetaTrack tr;
  while (std::getline(in, line)) {
    std::vector<double> v;
    std::stringstream ls(line);
    for (std::string c; std::getline(ls, c, ',');) v.push_back(std::strtod(c.c_str(), nullptr));
    if (v.size() <= std::max(ct, cth)) continue;
    tr.t.push_back(v[ct]);
    tr.theta.push_back(v[cth]);
  }
  if (tr.t.size() < 2) throw std::runtime_error(path + ": fewer than 2 rows");
  return tr;
}

// theta > 0 tips the block towards +x, about its +x base corner.
cv::Point2d SampleRocked(const SampleLed& led, double theta) {
  const double px = theta >= 0 ? kSampleHalfWidthM : -kSampleHalfWidthM;
  const double c = std::cos(theta), s = std::sin(theta), dx = led.x - px;
  return {px + c * dx + s * led.z, -s * dx + c * led.z};
}

cv::Mat RenderSampleFrame(const rocklab::test::TestCamera& cam, const ThetaTrack& truth, double t, cv::RNG& rng) {
  cv::Mat light(cam.height, cam.width, CV_64F, cv::Scalar(kSampleBackground));
  const int r = static_cast<int>(std::ceil(5 * kSampleSpotPx));
  for (const SampleLed& led : kSampleLeds) {
    for (int b = 0; b < kSampleBlurSteps; ++b) {
      const cv::Point2d p = SampleRocked(led, truth.At(t + (b + 0.5) / kSampleBlurSteps * kSampleExposureS));
      const cv::Point2d uv = cam.Project(p.x, p.y);
      for (int y = std::max(0, static_cast<int>(uv.y) - r); y <= std::min(cam.height - 1, static_cast<int>(uv.y) + r);
           ++y) {
        for (int x = std::max(0, static_cast<int>(uv.x) - r); x <= std::min(cam.width - 1, static_cast<int>(uv.x) + r);
             ++x) {
          const double d2 = (x - uv.x) * (x - uv.x) + (y - uv.y) * (y - uv.y);
          light.at<double>(y, x) +=
              kSamplePeak / kSampleBlurSteps * std::exp(-d2 / (2 * kSampleSpotPx * kSampleSpotPx));
        }
      }
    }
  }
  return rocklab::test::SensorFrame(light, kSampleNoise, rng);
}

void WriteSampleRig(const std::string& path, const rocklab::test::TestCamera& cam, double fps) {
  std::ofstream r(path);
  r.precision(7);
  r << "# The video sample's rig (data/README.md, \"The video sample\"): block 1 (0.247 x 1.0 m)\n"
       "# filmed from the side by one camera with four LEDs on the block's face. Written by\n"
       "# rocklab_render_video with the video; the marks are where its camera sees them.\n"
       "name = \"video-sample-block1\"\n"
    << "sample_rate_hz = " << fps << "              # the camera's frame rate\n\n"
    << "[block]\nwidth_m = 0.247\nheight_m = 1.0\n\n[theta_dot]\nwindow_s = 0.05\norder = 2\n\n"
    << "[[camera]]\nname = \"side\"\nled = [";
  for (std::size_t i = 0; i < std::size(kSampleLeds); ++i) {
    r << (i == 0 ? " " : ",\n        ") << "{ name = \"" << kSampleLeds[i].name << "\", x_m = " << kSampleLeds[i].x
      << ", z_m = " << kSampleLeds[i].z << " }";
  }
  r << " ]\n\n[camera.video]                      # every key: docs/video.md\n"
    << "exposure_s = " << kSampleExposureS << "                  # frame times are mid-exposure\n"
    << "threshold = 40                       # 8-bit level an LED's pixels exceed\n"
    << "gate_m = 0.08                        # the block starts held at 0.12 rad: its upper LEDs 66 mm from\n"
    << "                                     # their places at rest, beyond the default gate (64 mm)\n"
    << "mark = [                             # reference marks on the LEDs' plane: image px, rig m\n";
  const double marks[][2] = {{-0.3, 0.1}, {0.3, 0.1}, {-0.3, 0.6}, {0.3, 0.6}, {0.0, 0.35}, {-0.15, 0.45}};
  for (const auto& m : marks) {
    const cv::Point2d uv = cam.Project(m[0], m[1]);
    r << "  { u_px = " << uv.x << ", v_px = " << uv.y << ", x_m = " << m[0] << ", z_m = " << m[1] << " },\n";
  }
  r << "]\n";
  for (const SampleLed& led : kSampleLeds) {
    for (const char* axis : {"x", "z"}) {
      r << "\n[[channel]]\nname = \"side_" << led.name << "_" << axis << "\"\nsensor = \"side." << led.name << "."
        << axis << "\"\nunit = \"m\"\ngain = 1.0                           # the video source delivers metres\n"
        << "raw_min = -2.0\nraw_max = 2.0\n";
    }
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4 || argc > 6) {
    std::fprintf(stderr, "usage: %s TRUTH.csv VIDEO.mkv RIG.toml [FPS] [DURATION_S]\n", argv[0]);
    return 2;
  }
  try {
    const ThetaTrack truth = ReadTruth(argv[1]);
    const int fps = argc > 4 ? std::atoi(argv[4]) : 200;
    const double duration = argc > 5 ? std::strtod(argv[5], nullptr) : truth.t.back() - truth.t.front();
    if (fps <= 0 || !(duration > 0)) throw std::runtime_error("FPS and DURATION_S must be > 0");
    const rocklab::test::TestCamera cam;
    rocklab::test::TestVideoWriter w(argv[2], false, cam.width, cam.height, fps, kSampleMjpegQ);
    cv::RNG rng(35);
    const int frames = static_cast<int>(std::floor(duration * fps + 1e-9));
    for (int k = 0; k < frames; ++k) {
      const double t = truth.t.front() + static_cast<double>(k) / fps;
      w.Write(RenderSampleFrame(cam, truth, t, rng), std::llround(k * 1000.0 / fps));
    }
    w.Close();
    WriteSampleRig(argv[3], cam, fps);
    // MJPEG's error: the first frames decoded against their rendering.
    cv::VideoCapture cap(argv[2], cv::CAP_FFMPEG);
    cv::RNG again(35);
    double sum2 = 0;
    long pixels = 0;
    cv::Mat decoded, gray;
    for (int k = 0; k < std::min(frames, 50) && cap.read(decoded); ++k) {
      cv::cvtColor(decoded, gray, cv::COLOR_BGR2GRAY);
      cv::Mat rendered = RenderSampleFrame(cam, truth, truth.t.front() + static_cast<double>(k) / fps, again);
      cv::Mat diff;
      cv::subtract(gray, rendered, diff, cv::noArray(), CV_64F);
      sum2 += diff.dot(diff);
      pixels += static_cast<long>(diff.total());
    }
    std::printf("MJPEG error against the rendering: RMS %.3f levels over %ld pixels\n",
                pixels > 0 ? std::sqrt(sum2 / pixels) : NAN, pixels);
    std::printf("%d frames (%dx%d px, %d frames/s) written to %s; rig %s\n", frames, cam.width, cam.height, fps,
                argv[2], argv[3]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rocklab_render_video: %s\n", e.what());
    return 1;
  }
  return 0;
}
