// Time that is right and input that is never silently wrong (issue 35),
// each on a video the test renders itself: a block rocking on one corner
// from rest, four LEDs drawn row by row at each row's own time (a rolling
// shutter when readout_s > 0) and averaged over the exposure, sensor noise,
// 8-bit quantisation; written lossless (FFV1) into Matroska, whose
// timestamps are whole milliseconds (rounded at 240 frames/s).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "daq/processor.h"
#include "daq/rig_config.h"
#include "daq/source.h"
#include "tests/scratch.h"
#include "tests/video/test_video.h"
#include "video/frame_reader.h"
#include "video/video_source.h"

namespace rocklab::video::timing {
namespace {

constexpr double kSpotPx = 1.2;     // LED spot sigma, px
constexpr double kLedPeak = 180;    // 8-bit levels over the background
constexpr double kBackgroundLevel = 12;
constexpr double kPixelNoise = 1.0;  // levels
constexpr double kThresholdLevel = 40;
constexpr int kBoxMarginPx = 3;     // DetectorOptions::margin_px
constexpr double kCornerX = 0.125;  // the block rocks on its corner at x = +0.125 m

struct LayoutLed {
  const char* name;
  double x, z;
};
const LayoutLed kLayout[] = {{"A", -0.08, 0.15}, {"B", 0.08, 0.15}, {"C", -0.08, 0.55}, {"D", 0.08, 0.55}};

// What the camera films and how.
struct Shot {
  double rate_hz{240};     // the camera's true frame rate
  double amplitude{0.04};  // theta(t) = amplitude (1 - cos(2 pi 2.5 t)), rad
  double exposure_s{0};
  double readout_s{0};     // rolling shutter: row y starts readout_s y / height after row 0
  int blur_steps{1};
  std::function<bool(int)> dark;   // frames with no LED lit
  bool glint{false};               // a reflection sweeping across LED C
  int glint_from{60}, glint_to{140};
};

double TruthTheta(const Shot& s, double t) { return s.amplitude * (1 - std::cos(2 * M_PI * 2.5 * t)); }

// An LED's place on the rig plane at theta >= 0 (clockwise about the corner).
cv::Point2d PlaneAt(const LayoutLed& led, double theta) {
  const double c = std::cos(theta), s = std::sin(theta), dx = led.x - kCornerX;
  return {kCornerX + c * dx + s * led.z, -s * dx + c * led.z};
}

void AddSpotRow(cv::Mat& light, int y, const cv::Point2d& uv, double sigma, double peak) {
  const double wy = std::exp(-(y - uv.y) * (y - uv.y) / (2 * sigma * sigma));
  const int r = static_cast<int>(std::ceil(5 * sigma));
  for (int x = static_cast<int>(uv.x) - r; x <= static_cast<int>(uv.x) + r; ++x) {
    if (x < 0 || x >= light.cols) continue;
    light.at<double>(y, x) += peak * wy * std::exp(-(x - uv.x) * (x - uv.x) / (2 * sigma * sigma));
  }
}

// Frame k: each row at its own time t_k + readout y / H, averaged over
// [that, that + exposure] in blur_steps positions.
cv::Mat RenderFrame(const test::TestCamera& cam, const Shot& s, int k, cv::RNG& rng) {
  cv::Mat light(cam.height, cam.width, CV_64F, cv::Scalar(kBackgroundLevel));
  const double tk = k / s.rate_hz;
  const bool lit = !(s.dark && s.dark(k));
  const int reach = static_cast<int>(std::ceil(5 * kSpotPx)) + 3;
  for (const LayoutLed& led : kLayout) {
    if (!lit) break;
    const cv::Point2d near = cam.Project(PlaneAt(led, TruthTheta(s, tk)).x, PlaneAt(led, TruthTheta(s, tk)).y);
    for (int y = std::max(0, static_cast<int>(near.y) - reach); y <= std::min(cam.height - 1, static_cast<int>(near.y) + reach);
         ++y) {
      const double t_row = tk + s.readout_s * y / cam.height;
      for (int b = 0; b < s.blur_steps; ++b) {
        const double t = t_row + (b + 0.5) / s.blur_steps * s.exposure_s;
        const cv::Point2d p = PlaneAt(led, TruthTheta(s, t));
        AddSpotRow(light, y, cam.Project(p.x, p.y), kSpotPx, kLedPeak / s.blur_steps);
      }
    }
  }
  if (s.glint && k >= s.glint_from && k < s.glint_to) {
    // A reflection (sigma 1.8 px) crossing LED C's rest place left to right, 60 px.
    const cv::Point2d c0 = cam.Project(kLayout[2].x, kLayout[2].z);
    const double f = static_cast<double>(k - s.glint_from) / (s.glint_to - s.glint_from);
    const cv::Point2d g(c0.x - 30 + 60 * f, c0.y + 0.5);
    for (int y = static_cast<int>(g.y) - 10; y <= static_cast<int>(g.y) + 10; ++y) AddSpotRow(light, y, g, 1.8, 180);
  }
  return test::SensorFrame(light, kPixelNoise, rng);
}

// The rig's reference marks (x, z), m.
const std::vector<std::array<double, 2>> kMarks = {{-0.3, 0.1}, {0.3, 0.1}, {-0.3, 0.6}, {0.3, 0.6}, {0.0, 0.35},
                                                   {-0.15, 0.45}};

std::string RigFor(const test::TestCamera& cam, double sample_rate_hz, const std::string& video_keys,
                   const std::vector<std::array<double, 2>>& marks = kMarks) {
  std::vector<test::RigLed> leds;
  for (const LayoutLed& led : kLayout) leds.push_back({led.name, led.x, led.z});
  std::ostringstream keys;
  keys << "threshold = " << kThresholdLevel << "\n" << video_keys;
  return test::VideoRigText(cam, sample_rate_hz, leds, keys.str(), marks);
}

// Renders `frames` frames (all but `skip`), stored at `stored_fps` with
// millisecond timestamps round(k 1000 / stored_fps), as Matroska does.
std::string WriteShot(const std::string& dir, const Shot& s, int frames, int stored_fps, int skip = -1,
                      const test::TestCamera& cam = test::TestCamera{}) {
  const std::string path = dir + "/shot.mkv";
  test::TestVideoWriter w(path, true, cam.width, cam.height, stored_fps);
  cv::RNG rng(35);
  for (int k = 0; k < frames; ++k) {
    const cv::Mat f = RenderFrame(cam, s, k, rng);
    if (k != skip) w.Write(f, std::llround(k * 1000.0 / stored_fps));
  }
  w.Close();
  return path;
}

struct StateSink : daq::ProcessorSink {
  std::vector<daq::BlockState> states;
  void OnBlockState(const daq::BlockState& b) override { states.push_back(b); }
};

struct ShotRun {
  std::vector<daq::BlockState> states;
  VideoStats stats;
  daq::ReadStatus end{};
  std::string error;
  std::vector<std::string> problems;
  double max_error{}, rms_error{};  // theta against the truth at each state's time
  int compared{};
};

// Whether one of the read's problems says `text`.
bool Said(const std::vector<std::string>& problems, const std::string& text) {
  for (const std::string& p : problems) {
    if (p.find(text) != std::string::npos) return true;
  }
  return false;
}

ShotRun ReadShot(const std::string& dir, const std::string& rig_text, const std::string& video, const Shot& s) {
  std::ofstream(dir + "/rig.toml") << rig_text;
  RegisterSources();
  const daq::RigConfig rig = daq::LoadRigConfig(dir + "/rig.toml");
  daq::SourceOptions options;
  options.rig = &rig;
  ShotRun r;
  options.on_problem = [&r](const daq::Problem& p) { r.problems.push_back(daq::ToString(p)); };
  std::unique_ptr<daq::Source> source = daq::OpenSource("video:" + video, options);
  StateSink sink;
  daq::Processor processor(rig, source->channel_names(), source->path(), sink);
  daq::Frame frame;
  while ((r.end = source->Next(frame)) == daq::ReadStatus::kFrame) processor.Process(frame);
  processor.Finish();
  r.error = source->error();
  r.stats = *VideoStatsOf(*source);
  r.states = sink.states;
  double sum2 = 0;
  for (const daq::BlockState& b : r.states) {
    if (!std::isfinite(b.theta_camera)) continue;
    const double e = b.theta_camera - TruthTheta(s, b.time_s);
    sum2 += e * e;
    r.max_error = std::max(r.max_error, std::abs(e));
    ++r.compared;
  }
  r.rms_error = r.compared > 0 ? std::sqrt(sum2 / r.compared) : NAN;
  return r;
}

// The theta noise the pixel noise allows with `leds` of the layout (first
// ones), in the oracle of video_test.cpp: the centroid's sigma
// (test::CentroidSigmaPx) at the plane scale of the LEDs' places, over
// sqrt of their spread. Bound: 5 sigma + 0.02 px of centroid bias, + `extra`.
double Spread(const std::vector<int>& leds) {
  double cx = 0, cz = 0, spread = 0;
  for (int i : leds) cx += kLayout[i].x / leds.size(), cz += kLayout[i].z / leds.size();
  for (int i : leds) spread += std::pow(kLayout[i].x - cx, 2) + std::pow(kLayout[i].z - cz, 2);
  return spread;
}

double ThetaBound(const std::vector<int>& leds, double extra) {
  const test::TestCamera cam;
  const double sigma_px =
      test::CentroidSigmaPx(kSpotPx, kLedPeak, kThresholdLevel, kBackgroundLevel, kBoxMarginPx, kPixelNoise);
  double m_per_px = 0;
  for (int i : leds) {
    const LayoutLed& l = kLayout[i];
    const cv::Point2d a = cam.Project(l.x, l.z), b = cam.Project(l.x + 1e-3, l.z), c = cam.Project(l.x, l.z + 1e-3);
    m_per_px = std::max({m_per_px, 1e-3 / std::hypot(b.x - a.x, b.y - a.y), 1e-3 / std::hypot(c.x - a.x, c.y - a.y)});
  }
  const double per_px = m_per_px / std::sqrt(Spread(leds));
  return 5 * sigma_px * per_px + 0.02 * per_px + extra;
}

// Every state on the grid t = k / rate, and which k are there.
std::vector<int64_t> GridIndices(const ShotRun& r, double rate_hz, double* worst_off_s) {
  std::vector<int64_t> k;
  *worst_off_s = 0;
  for (const daq::BlockState& b : r.states) {
    const int64_t n = std::llround(b.time_s * rate_hz);
    *worst_off_s = std::max(*worst_off_s, std::abs(b.time_s - n / rate_hz));
    k.push_back(n);
  }
  return k;
}

TEST(VideoTime, RoundedMatroskaTimesAreStampedOnTheFrameGridAndSaidSo) {
  const std::string dir = test::ScratchDir("video_time_mkv240");
  Shot s;
  constexpr int kN = 160, kSkip = 90;
  const std::string video = WriteShot(dir, s, kN, 240, kSkip);
  const ShotRun r = ReadShot(dir, RigFor(test::TestCamera{}, 240, ""), video, s);
  // Oracle: the frames the test wrote, frame k exposed at k / 240 s; the
  // container holds round(k 1000 / 240) ms, up to 0.5 ms off (at k = 3:
  // 12.5 ms stored as 13 ms, or 12).
  double off = 0;
  const std::vector<int64_t> k = GridIndices(r, 240.0, &off);
  EXPECT_LT(off, 1e-9);
  ASSERT_EQ(k.size(), static_cast<std::size_t>(kN - 1));
  for (int64_t i = 0; i < kN - 1; ++i) EXPECT_EQ(k[static_cast<std::size_t>(i)], i < kSkip ? i : i + 1);
  EXPECT_EQ(r.stats.frames.dropped, 1);
  EXPECT_EQ(r.stats.frames.repeated, 0);
  EXPECT_GT(r.stats.frames.off_grid, kN / 2);
  EXPECT_GT(r.stats.frames.max_off_grid_s, 0.4e-3);
  EXPECT_LE(r.stats.frames.max_off_grid_s, 0.5e-3 + 1e-6);
  EXPECT_TRUE(Said(r.problems, "stamped t0 + k /"));
  // Oracle: the truth at those times; all four LEDs in view.
  const double bound = ThetaBound({0, 1, 2, 3}, 0.0);
  std::printf("MKV 240 frames/s: theta error RMS %.3g, max %.3g rad (bound %.3g) over %d frames\n", r.rms_error,
              r.max_error, bound, r.compared);
  EXPECT_EQ(r.compared, kN - 1);
  EXPECT_LT(r.max_error, bound);
}

TEST(VideoTime, ASlowMotionExportIsStampedAtTheRigsOrTheGivenRate) {
  const std::string dir = test::ScratchDir("video_time_slowmo");
  Shot s;  // filmed at 240 frames/s, stored at 30
  constexpr int kN = 120;
  const std::string video = WriteShot(dir, s, kN, 30);
  const ShotRun r = ReadShot(dir, RigFor(test::TestCamera{}, 240, "fps = 240.0\n"), video, s);
  // Oracle: frame k filmed at k / 240 s.
  double off = 0;
  const std::vector<int64_t> k = GridIndices(r, 240.0, &off);
  EXPECT_LT(off, 1e-9);
  ASSERT_EQ(k.size(), static_cast<std::size_t>(kN));
  for (int64_t i = 0; i < kN; ++i) EXPECT_EQ(k[static_cast<std::size_t>(i)], i);
  EXPECT_EQ(r.stats.frames.dropped, 0);
  EXPECT_EQ(r.stats.frames.repeated, 0);
  EXPECT_DOUBLE_EQ(r.stats.rate_hz, 240.0);
  EXPECT_LT(r.max_error, ThetaBound({0, 1, 2, 3}, 0.0));

  // The same through `rocklab track --fps 240` with a rig without fps: the
  // CSV's times are k / 240 (9 decimals).
  std::ofstream(dir + "/rig_nofps.toml") << RigFor(test::TestCamera{}, 240, "");
  const std::string cmd = std::string(ROCKLAB_BINARY) + " track " + video + " --rig " + dir +
                          "/rig_nofps.toml --fps 240 --out " + dir + "/raw.csv 2> " + dir + "/track.err";
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  std::ifstream csv(dir + "/raw.csv");
  std::string line;
  std::getline(csv, line);
  int64_t row = 0;
  while (std::getline(csv, line)) {
    EXPECT_NEAR(std::strtod(line.c_str(), nullptr), row / 240.0, 1e-9) << row;
    ++row;
  }
  EXPECT_EQ(row, kN);
}

TEST(VideoTime, ExposureAndRollingShutterAreTakenOutOfTheta) {
  const std::string dir = test::ScratchDir("video_time_shutter");
  Shot s;
  s.exposure_s = 0.004;
  s.readout_s = 0.004;
  s.blur_steps = 8;
  constexpr int kN = 150;
  const std::string video = WriteShot(dir, s, kN, 240);
  // Oracle: the truth at each state's time, which is the mid-exposure of
  // row 0. Bound: the pixel noise's (5 sigma + bias) plus the correction's
  // own error (docs/video.md, Time): an LED seen delta after row 0 is taken
  // back along the secant rate of the last two fits, off by at most
  // a'' (delta^2 + Delta delta) / 2 per LED, a'' <= (theta'' + theta'^2) L
  // the LED's acceleration (L its distance from the corner, the block
  // turning about it), delta <= the readout, Delta = 1/240 s; the rigid fit
  // turns position errors into theta by 1 / sqrt(S). The centroid of a spot
  // blurred over E is the mid-exposure place to a'' E^2 / 24.
  const double w = 2 * M_PI * 2.5, th2 = s.amplitude * w * w + std::pow(s.amplitude * w, 2);
  double lever = 0;
  for (const LayoutLed& l : kLayout) lever = std::max(lever, std::hypot(l.x - kCornerX, l.z));
  const double delta = s.readout_s, frame = 1 / s.rate_hz;
  const double model =
      th2 * lever * ((delta * delta + frame * delta) / 2 + s.exposure_s * s.exposure_s / 24) / std::sqrt(Spread({0, 1, 2, 3}));
  const double bound = ThetaBound({0, 1, 2, 3}, model);
  const ShotRun r = ReadShot(dir, RigFor(test::TestCamera{}, 240, "exposure_s = 0.004\nreadout_s = 0.004\n"), video, s);
  std::printf("4 ms exposure, 4 ms readout: theta error RMS %.3g, max %.3g rad (bound %.3g) over %d frames\n",
              r.rms_error, r.max_error, bound, r.compared);
  EXPECT_EQ(r.compared, kN);
  EXPECT_LT(r.max_error, bound);
  // The same video read as if the shutter were global and instant: theta
  // late by half an exposure and part of a readout, past the bound (the
  // test sees what it checks).
  const ShotRun plain = ReadShot(dir, RigFor(test::TestCamera{}, 240, ""), video, s);
  std::printf("  read without exposure_s and readout_s: theta error RMS %.3g, max %.3g rad\n", plain.rms_error,
              plain.max_error);
  EXPECT_GT(plain.max_error, bound);
}

TEST(VideoHealth, AGlintMergedWithAnLedIsRejectedNotAveraged) {
  const std::string dir = test::ScratchDir("video_glint");
  Shot s;
  s.amplitude = 0.01;
  s.glint = true;
  constexpr int kN = 200;
  const std::string video = WriteShot(dir, s, kN, 240);
  const ShotRun r = ReadShot(dir, RigFor(test::TestCamera{}, 240, ""), video, s);
  // Oracle: the truth; the frames where the reflection lies on LED C are
  // measured with the other three (their bound), none with C's merged blob.
  const double bound = ThetaBound({0, 1, 3}, 0.0);
  std::printf("glint across LED C: %lld LED samples rejected as outliers, %lld ambiguous; theta error max %.3g rad "
              "(bound %.3g) over %d frames\n",
              static_cast<long long>(r.stats.track.outliers), static_cast<long long>(r.stats.track.ambiguous),
              r.max_error, bound, r.compared);
  EXPECT_LT(r.max_error, bound);
  EXPECT_GT(r.stats.track.outliers, 0);
  EXPECT_EQ(r.compared, kN);  // three LEDs always left: a theta every frame
  EXPECT_TRUE(Said(r.problems, "LED C: blob of"));
}

TEST(VideoHealth, NoLedForLongerThanMaxDarkIsAnErrorNamingTheFileAndFrame) {
  const std::string dir = test::ScratchDir("video_dark");
  Shot s;
  s.rate_hz = 100;
  s.dark = [](int k) { return k >= 40; };
  const std::string video = WriteShot(dir, s, 120, 100);
  // Oracle: frame 39 is the last lit, at 0.39 s; frame 90 (0.90 s) is the
  // first more than max_dark_s = 0.5 s after it.
  const ShotRun r = ReadShot(dir, RigFor(test::TestCamera{}, 100, "max_dark_s = 0.5\n"), video, s);
  EXPECT_EQ(r.end, daq::ReadStatus::kError);
  EXPECT_NE(r.error.find(video + ":91: frame 90 (t = 0.900000 s): no LED identified for 0.510 s"), std::string::npos)
      << r.error;
  EXPECT_EQ(r.states.size(), 90u);
  // Asked otherwise (0): read to the end, the dark frames without theta.
  const ShotRun on = ReadShot(dir, RigFor(test::TestCamera{}, 100, "max_dark_s = 0\n"), video, s);
  EXPECT_EQ(on.end, daq::ReadStatus::kEnd);
  EXPECT_EQ(on.compared, 40);
}

// Oracle for the refusals: the rig the test wrote, its lines.
std::string RigError(const std::string& name, const std::string& rig_text) {
  return test::VideoOpenError(name, rig_text, "");
}

int LineOf(const std::string& text, std::size_t at) {
  return 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(at), '\n'));
}

TEST(VideoHealth, SwappedMarksAreRefusedNamingTheMark) {
  const std::string good = RigFor(test::TestCamera{}, 100, "");
  // Six marks, the rig coordinates of the first two swapped: a least-squares
  // homography that misses them by centimetres.
  std::string six = good;
  const std::size_t m1 = six.find("x_m = -0.3, z_m = 0.1"), m2 = six.find("x_m = 0.3, z_m = 0.1");
  six.replace(m2, 20, "x_m = -0.3, z_m = 0.1");
  six.replace(m1, 21, "x_m = 0.3, z_m = 0.1 ");
  const std::string e1 = RigError("video_marks_six", six);
  const int first_mark = LineOf(six, six.find("  { u_px"));
  EXPECT_NE(e1.find("rig.toml:" + std::to_string(first_mark) + ": key 'camera.video.mark': the marks fold the plane"),
            std::string::npos)
      << e1;
  // Four marks (the homography passes through any four), two swapped: it
  // folds the plane between them too.
  std::string four = six;
  for (int i = 0; i < 2; ++i) {
    const std::size_t at = four.find("  { u_px", four.find("x_m = 0.3, z_m = 0.6"));
    four.erase(at, four.find('\n', at) - at + 1);
  }
  const std::string e2 = RigError("video_marks_four", four);
  EXPECT_NE(e2.find("rig.toml:" + std::to_string(first_mark) + ": key 'camera.video.mark': the marks fold the plane"),
            std::string::npos)
      << e2;
  // One mark typed 20 px off (u_px): the six marks' homography misses it
  // by centimetres, and the error names its line.
  std::string typo = good;
  const std::size_t fifth = typo.find("x_m = 0, z_m = 0.35");
  const std::size_t u_at = typo.rfind("u_px = ", fifth) + 7;
  const double u = std::strtod(typo.c_str() + u_at, nullptr);
  typo.replace(u_at, typo.find(',', u_at) - u_at, std::to_string(u + 20));
  const std::string e3 = RigError("video_marks_typo", typo);
  EXPECT_NE(e3.find("rig.toml:" + std::to_string(LineOf(typo, fifth)) + ": key 'camera.video.mark': this mark is"),
            std::string::npos)
      << e3;
  // The good marks open (and then fail on the missing video, not the marks).
  EXPECT_NE(RigError("video_marks_good", good).find("none.mkv: cannot be opened"), std::string::npos);
}

TEST(VideoHealth, ATruncatedFileIsCountedAsFramesMissingAtTheEnd) {
  const std::string dir = test::ScratchDir("video_truncated");
  Shot s;
  s.rate_hz = 100;
  constexpr int kN = 100;
  const std::string video = WriteShot(dir, s, kN, 100);
  // Cut the file in the middle of its frames (the header, with the
  // segment's duration, stays).
  const auto size = std::filesystem::file_size(video);
  std::filesystem::resize_file(video, size / 2);
  const ShotRun r = ReadShot(dir, RigFor(test::TestCamera{}, 100, ""), video, s);
  // Oracle: 100 frames written; what the reader delivered and what it says
  // is missing make them up (one frame of slack in the container's count).
  std::printf("truncated to half: %lld frames read, %lld missing at the end (announced %lld)\n",
              static_cast<long long>(r.stats.frames.frames), static_cast<long long>(r.stats.frames.missing_at_end),
              static_cast<long long>(r.stats.frames.announced));
  EXPECT_LT(r.stats.frames.frames, 70);
  EXPECT_NEAR(static_cast<double>(r.stats.frames.frames + r.stats.frames.missing_at_end), kN, 1.0);
  EXPECT_TRUE(Said(r.problems, "the read ended"));
}

TEST(VideoHealth, AFrameSizeChangeInAnImageSequenceStopsTheReadNamingTheFrame) {
  const std::string dir = test::ScratchDir("video_resize_png");
  std::filesystem::create_directories(dir + "/frames");
  Shot s;
  s.rate_hz = 100;
  const test::TestCamera cam;
  cv::RNG rng(35);
  for (int k = 0; k < 30; ++k) {
    cv::Mat f = RenderFrame(cam, s, k, rng);
    if (k >= 20) cv::resize(f, f, cv::Size(240, 180), 0, 0, cv::INTER_AREA);
    char name[64];
    std::snprintf(name, sizeof name, "/frames/%06d.png", k);
    cv::imwrite(dir + name, f);
  }
  const ShotRun r = ReadShot(dir, RigFor(cam, 100, "fps = 100.0\n"), dir + "/frames/%06d.png", s);
  // Oracle: 20 frames of 320x240, then 240x180 from frame 20.
  EXPECT_EQ(r.end, daq::ReadStatus::kError);
  EXPECT_NE(r.error.find("%06d.png:21: frame 20 (read 21 of the file): the frame size changed from 320x240 to "
                         "240x180 px"),
            std::string::npos)
      << r.error;
  EXPECT_EQ(r.states.size(), 20u);
}

// The same in one MJPEG stream in Matroska (each JPEG carries its size):
// OpenCV's FFmpeg reader handed back frames of the first size, stale or
// garbled, and theta froze; the libavcodec reader sees the new size.
TEST(VideoHealth, AFrameSizeChangeInsideAStreamStopsTheReadCountingTheRest) {
  const std::string dir = test::ScratchDir("video_resize_mjpeg");
  Shot s;
  s.rate_hz = 100;
  const test::TestCamera cam;
  constexpr int kN = 30, kChange = 20;
  {
    test::TestVideoWriter w(dir + "/shot.mkv", false, cam.width, cam.height, 100);
    cv::RNG rng(35);
    for (int k = 0; k < kN; ++k) {
      cv::Mat f = RenderFrame(cam, s, k, rng);
      if (k >= kChange) cv::resize(f, f, cv::Size(240, 180), 0, 0, cv::INTER_AREA);
      w.Write(f, k * 10);
    }
    w.Close();
  }
  const ShotRun r = ReadShot(dir, RigFor(cam, 100, ""), dir + "/shot.mkv", s);
  // Oracle: 20 frames of 320x240 written, then 10 of 240x180.
  EXPECT_EQ(r.end, daq::ReadStatus::kError);
  EXPECT_NE(r.error.find("shot.mkv:21: frame 20 (read 21 of the file): the frame size changed from 320x240 to "
                         "240x180 px; 10 frame(s) from there to the end not tracked"),
            std::string::npos)
      << r.error;
  EXPECT_EQ(r.stats.frames.after_size_change, kN - kChange);
  EXPECT_EQ(r.states.size(), static_cast<std::size_t>(kChange));
  // The frames before the change are tracked as in any MJPEG stream.
  EXPECT_EQ(r.compared, kChange);
}

TEST(VideoHealth, AnUncalibratedLensDoesNotMakeTheDroppedLedsFlipBetweenFrames) {
  const std::string dir = test::ScratchDir("video_flip");
  Shot s;
  s.rate_hz = 100;
  s.amplitude = 0;  // at rest: theta 0 throughout
  test::TestCamera cam;
  cam.k1 = -0.05;  // a lens no intrinsics describe: every LED a little off the homography
  constexpr int kN = 100;
  const std::string video = WriteShot(dir, s, kN, 100, -1, cam);
  // Marks and LEDs symmetric about the lens's axis: mirrored LEDs are
  // equally off, and the noise picks which one the fit drops.
  std::ofstream(dir + "/rig.toml") << RigFor(cam, 100, "residual_m = 0.0015\n",
                                             {{-0.3, 0.1}, {0.3, 0.1}, {-0.3, 0.6}, {0.3, 0.6}, {0.0, 0.35}, {0.0, 0.5}});
  RegisterSources();
  const daq::RigConfig rig = daq::LoadRigConfig(dir + "/rig.toml");
  daq::SourceOptions options;
  options.rig = &rig;
  std::unique_ptr<daq::Source> source = daq::OpenSource("video:" + video, options);
  daq::Frame frame;
  // Oracle: the block does not move, so which LEDs the fit drops is a
  // property of the lens, not of the frame: the set of inconsistent LEDs
  // (flags bit 16, columns after the 8 coordinates: area, peak, flags per
  // LED) may settle once, then stays. (Without the hysteresis it changed
  // 40 times in these 100 frames.)
  int changes = 0, frames = 0, dropping = 0;
  unsigned last = 0;
  while (source->Next(frame) == daq::ReadStatus::kFrame) {
    unsigned mask = 0;
    for (unsigned i = 0; i < 4; ++i) {
      if (static_cast<unsigned>(frame.values[8 + 3 * i + 2]) & kLedInconsistent) mask |= 1u << i;
    }
    if (frames > 0 && mask != last) ++changes;
    dropping += mask != 0 ? 1 : 0;
    last = mask;
    ++frames;
  }
  const VideoStats& v = *VideoStatsOf(*source);
  std::printf("uncalibrated lens: %d frames dropping LEDs (last set %u), the dropped set changed %d times, %lld drops held\n",
              dropping, last, changes, static_cast<long long>(v.track.held_drops));
  EXPECT_EQ(frames, kN);
  EXPECT_GT(dropping, kN / 2);  // the case is there: the lens makes the fit drop LEDs
  EXPECT_LE(changes, 1);
}


// Damaged MJPEG AVI files (issue 35): corrupt bytes inside frames, 20 KB
// of zeros over the middle of the file, a cut. Each frame carries its own
// number k, 10 bits as 8 x 8 px blocks along the top rows (level 32 for a
// 1, the background's 12 for a 0: under the LED threshold, so the tracker
// does not see it; on JPEG's 8 x 8 grid, so it decodes clean): the oracle
// of which frame the reader delivered, read off its pixels, not its time.
constexpr int kCodeBits = 10;
constexpr double kCodeOn = 32;

cv::Mat RenderNumbered(const test::TestCamera& cam, const Shot& s, int k, cv::RNG& rng) {
  cv::Mat f = RenderFrame(cam, s, k, rng);
  for (int b = 0; b < kCodeBits; ++b) {
    f(cv::Rect(8 * b, 0, 8, 8)).setTo(((k >> b) & 1) != 0 ? kCodeOn : kBackgroundLevel);
  }
  return f;
}

// The number a delivered frame carries (each block's mean against the
// midpoint of the two levels).
int ReadNumber(const cv::Mat& gray) {
  int k = 0;
  for (int b = 0; b < kCodeBits; ++b) {
    if (cv::mean(gray(cv::Rect(8 * b, 0, 8, 8)))[0] > 0.5 * (kCodeOn + kBackgroundLevel)) k |= 1 << b;
  }
  return k;
}

// An MJPEG AVI of `frames` numbered frames at `rate` (the writer's: every
// frame in its place on the 1 / rate grid, the index at the end).
std::string WriteNumberedAvi(const std::string& dir, const Shot& s, int frames) {
  const std::string path = dir + "/shot.avi";
  const test::TestCamera cam;
  test::TestVideoWriter w(path, false, cam.width, cam.height, static_cast<int>(s.rate_hz));
  cv::RNG rng(35);
  for (int k = 0; k < frames; ++k) w.Write(RenderNumbered(cam, s, k, rng), std::llround(k * 1000.0 / s.rate_hz));
  w.Close();
  return path;
}

// Where each video chunk ("00dc") of an AVI's movi list has its data:
// (file offset, bytes), in the file's order. The test's own walk of RIFF.
std::vector<std::pair<std::size_t, std::size_t>> AviFrameChunks(const std::string& bytes) {
  const auto u32 = [&](std::size_t at) {
    return static_cast<std::size_t>(static_cast<uint8_t>(bytes[at])) |
           static_cast<std::size_t>(static_cast<uint8_t>(bytes[at + 1])) << 8 |
           static_cast<std::size_t>(static_cast<uint8_t>(bytes[at + 2])) << 16 |
           static_cast<std::size_t>(static_cast<uint8_t>(bytes[at + 3])) << 24;
  };
  std::vector<std::pair<std::size_t, std::size_t>> chunks;
  const std::size_t movi = bytes.find("movi");
  if (movi == std::string::npos || movi < 8) return chunks;
  const std::size_t end = movi - 4 + u32(movi - 4);  // the LIST's size counts from "movi"
  for (std::size_t at = movi + 4; at + 8 <= std::min(end, bytes.size());) {
    const std::size_t size = u32(at + 4);
    if (bytes.compare(at, 4, "00dc") == 0) chunks.emplace_back(at + 8, size);
    at += 8 + size + (size & 1);
  }
  return chunks;
}

std::string ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

void WriteBytes(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

// A file read through FrameReader (the video source's reader): per frame
// delivered, the number it carries, its number and its time.
struct Delivered {
  std::vector<int> carried;
  std::vector<int64_t> numbers;
  std::vector<double> times;
  FrameCounts counts;
};

Delivered ReadNumbered(const std::string& path) {
  FrameReader reader(path, false, std::nullopt);
  Delivered d;
  cv::Mat gray;
  double t = 0;
  int64_t n = 0;
  while (reader.Next(gray, t, n)) {
    d.carried.push_back(ReadNumber(gray));
    d.numbers.push_back(n);
    d.times.push_back(t);
  }
  d.counts = reader.counts();
  return d;
}

// Every frame delivered carries its own number k (0 <= k < n), as its
// number, at its time k / rate_hz; each of the n frames not in `lost` is
// delivered once, and none of those in `lost`.
void ExpectEachFrameOnceBut(const Delivered& d, int n, double rate_hz, const std::vector<int>& lost) {
  std::vector<int> seen(static_cast<std::size_t>(n), 0);
  for (std::size_t i = 0; i < d.numbers.size(); ++i) {
    const int k = d.carried[i];
    ASSERT_GE(k, 0);
    ASSERT_LT(k, n);
    ++seen[static_cast<std::size_t>(k)];
    EXPECT_EQ(d.numbers[i], k);
    EXPECT_NEAR(d.times[i], k / rate_hz, 1e-9) << "frame " << k;
  }
  for (int k = 0; k < n; ++k) {
    const bool is_lost = std::find(lost.begin(), lost.end(), k) != lost.end();
    EXPECT_EQ(seen[static_cast<std::size_t>(k)], is_lost ? 0 : 1) << "frame " << k;
  }
}

// Frames counted as not delivered: every way the reader has to say so.
int64_t Counted(const FrameCounts& c) {
  return c.unreadable + c.dropped + c.repeated + c.backwards + c.missing_at_end + c.after_size_change;
}

// Corrupt bytes inside 23 frames' JPEG data (their chunks intact): OpenCV's
// reader ended at the first frame it could not decode, "0 unreadable"; the
// libavcodec reader, decoding leniently, delivered all 200, the damaged
// ones concealed (their LEDs' light not the scene's). Oracle: the 200
// frames written; the damaged ones known (48 random bytes in the middle of
// each one's scan: every one refused by a strict decoder). Every undamaged
// frame is delivered with its own number and time k / rate; every damaged
// one is counted unreadable, once, at its number (no drop said for it) and
// named with its time; delivered + counted = 200.
TEST(VideoHealth, CorruptMjpegFramesAreCountedUnreadableWithTheirTimes) {
  const std::string dir = test::ScratchDir("video_corrupt_mjpeg");
  Shot s;
  s.rate_hz = 100;
  constexpr int kN = 200;
  const std::string video = WriteNumberedAvi(dir, s, kN);
  std::string bytes = ReadBytes(video);
  const auto chunks = AviFrameChunks(bytes);
  ASSERT_EQ(chunks.size(), static_cast<std::size_t>(kN));
  // 48 random bytes in the middle of the scan of frames 20, 28, ..., 196.
  cv::RNG rng(350);
  std::vector<int> damaged;
  for (int k = 20; k < kN; k += 8) {
    damaged.push_back(k);
    const std::size_t at = chunks[static_cast<std::size_t>(k)].first + chunks[static_cast<std::size_t>(k)].second / 2;
    for (std::size_t i = 0; i < 48; ++i) bytes[at + i] = static_cast<char>(rng.uniform(0, 256));
  }
  WriteBytes(video, bytes);

  const Delivered d = ReadNumbered(video);
  const FrameCounts& c = d.counts;
  std::printf("corrupt MJPEG: %zu of %d frames delivered, %lld unreadable, %lld dropped, %lld missing at the end "
              "(%zu frames damaged)\n",
              d.numbers.size(), kN, static_cast<long long>(c.unreadable), static_cast<long long>(c.dropped),
              static_cast<long long>(c.missing_at_end), damaged.size());
  ExpectEachFrameOnceBut(d, kN, s.rate_hz, damaged);
  if (HasFatalFailure()) return;
  EXPECT_EQ(c.unreadable, static_cast<int64_t>(damaged.size()));
  EXPECT_EQ(c.dropped, 0);  // no frame went missing from the file: the unreadable ones are counted as such
  EXPECT_EQ(c.missing_at_end, 0);
  EXPECT_EQ(static_cast<int64_t>(d.numbers.size()) + Counted(c), kN);
  EXPECT_EQ(static_cast<int64_t>(d.numbers.size()), kN - c.unreadable);

  // Through the video source (`rocklab track`, `reconstruct`): counted in
  // its summary, each unreadable frame named with its time.
  const ShotRun r = ReadShot(dir, RigFor(test::TestCamera{}, 100, ""), video, s);
  EXPECT_EQ(r.stats.frames.unreadable, c.unreadable);
  EXPECT_EQ(r.stats.frames.frames, static_cast<int64_t>(d.numbers.size()));
  EXPECT_EQ(r.end, daq::ReadStatus::kEnd);
  const std::string summary = VideoSummary(r.stats);
  EXPECT_NE(summary.find(std::to_string(c.unreadable) + " unreadable"), std::string::npos) << summary;
  // Said as each comes (the first 20 of them), the frame named with its time.
  int named = 0;
  for (const std::string& p : r.problems) named += p.find("could not be decoded") != std::string::npos ? 1 : 0;
  EXPECT_EQ(named, 20);
  bool first = false;
  for (const std::string& p : r.problems) {
    first = first || p.find("shot.avi:21: 1 frame(s) before this one could not be decoded (damaged) (the last: frame "
                            "20, t = 0.200000 s)") != std::string::npos;
  }
  EXPECT_TRUE(first);
}

// 20 KB of zeros over the middle of an MJPEG AVI: the frames under them
// are lost, the demuxer finds its way to the next chunk, and, timing a
// frame by the chunks read so far, stamped the frames after it early
// (here 0.2 s: 20 frames) with "0 dropped". Oracle: the numbers the frames
// carry; every frame after the zeros at k / rate; the frames under the
// zeros (the test knows them from the chunks it overwrote) counted dropped
// or unreadable, each once.
TEST(VideoHealth, ZerosInsideAnMjpegAviKeepTheTimesOfTheFramesAfterThem) {
  const std::string dir = test::ScratchDir("video_zeros_mjpeg");
  Shot s;
  s.rate_hz = 100;
  constexpr int kN = 200;
  const std::string video = WriteNumberedAvi(dir, s, kN);
  std::string bytes = ReadBytes(video);
  const auto chunks = AviFrameChunks(bytes);
  ASSERT_EQ(chunks.size(), static_cast<std::size_t>(kN));
  constexpr std::size_t kZeros = 20 * 1024;
  const std::size_t from = chunks[80].first + 100;  // inside frame 80's data
  bytes.replace(from, kZeros, kZeros, '\0');
  WriteBytes(video, bytes);
  // The frames whose bytes the zeros touch (their chunk header or data).
  std::vector<int> hit;
  for (int k = 0; k < kN; ++k) {
    const auto& ch = chunks[static_cast<std::size_t>(k)];
    if (ch.first + ch.second > from && ch.first - 8 < from + kZeros) hit.push_back(k);
  }
  ASSERT_GE(hit.size(), 3u);

  const Delivered d = ReadNumbered(video);
  const FrameCounts& c = d.counts;
  std::printf("20 KB of zeros over frames %d..%d: %zu of %d frames delivered, %lld dropped in %lld places, "
              "%lld unreadable\n",
              hit.front(), hit.back(), d.numbers.size(), kN, static_cast<long long>(c.dropped),
              static_cast<long long>(c.drop_events), static_cast<long long>(c.unreadable));
  ExpectEachFrameOnceBut(d, kN, s.rate_hz, hit);
  if (HasFatalFailure()) return;
  EXPECT_EQ(c.dropped + c.unreadable, static_cast<int64_t>(hit.size()));
  EXPECT_EQ(c.missing_at_end, 0);
  EXPECT_EQ(static_cast<int64_t>(d.numbers.size()) + Counted(c), kN);
  const ShotRun r = ReadShot(dir, RigFor(test::TestCamera{}, 100, ""), video, s);
  EXPECT_EQ(r.stats.frames.dropped, c.dropped);
  EXPECT_EQ(r.stats.frames.frames, static_cast<int64_t>(d.numbers.size()));
  EXPECT_TRUE(Said(r.problems, " frame(s) dropped before this one"));
}


// A recording cut short: an MJPEG AVI truncated inside frame 120's data
// (its index, at the end, gone). Oracle: the header announces the 200
// frames written; frames 0..119 delivered with their numbers and times, the
// cut frame delivered or counted unreadable, the rest counted missing at
// the end: delivered + counted = 200, and said.
TEST(VideoHealth, ATruncatedMjpegAviIsCountedAsFramesMissingAtTheEnd) {
  const std::string dir = test::ScratchDir("video_truncated_avi");
  Shot s;
  s.rate_hz = 100;
  constexpr int kN = 200, kCut = 120;
  const std::string video = WriteNumberedAvi(dir, s, kN);
  const auto chunks = AviFrameChunks(ReadBytes(video));
  ASSERT_EQ(chunks.size(), static_cast<std::size_t>(kN));
  std::filesystem::resize_file(video, chunks[kCut].first + chunks[kCut].second / 2);

  const Delivered d = ReadNumbered(video);
  const FrameCounts& c = d.counts;
  std::printf("truncated AVI: %zu of %d frames delivered, %lld unreadable, %lld missing at the end (announced %lld)\n",
              d.numbers.size(), kN, static_cast<long long>(c.unreadable), static_cast<long long>(c.missing_at_end),
              static_cast<long long>(c.announced));
  ASSERT_GE(d.numbers.size(), static_cast<std::size_t>(kCut));
  for (std::size_t i = 0; i < d.numbers.size(); ++i) {
    EXPECT_EQ(d.carried[i], static_cast<int>(i));
    EXPECT_EQ(d.numbers[i], static_cast<int64_t>(i));
    EXPECT_NEAR(d.times[i], static_cast<double>(i) / s.rate_hz, 1e-9);
  }
  EXPECT_LE(d.numbers.size(), static_cast<std::size_t>(kCut + 1));
  EXPECT_EQ(c.announced, kN);
  EXPECT_EQ(c.dropped, 0);
  EXPECT_EQ(static_cast<int64_t>(d.numbers.size()) + Counted(c), kN);
  const ShotRun r = ReadShot(dir, RigFor(test::TestCamera{}, 100, ""), video, s);
  EXPECT_EQ(r.stats.frames.missing_at_end, c.missing_at_end);
  EXPECT_TRUE(Said(r.problems, "the read ended"));
}

// A red LED filmed by a colour camera, MJPEG 4:4:4 in AVI through the
// `video:` file path (libavcodec): the rig's `channel = "red"` reads the
// decoded frame's colour, not its luma plane. Oracle: the LEDs light the
// red channel only, kLedPeak over a background of kBackgroundLevel in all
// three; the luma (0.299 R + 0.587 G + 0.114 B) keeps 0.299 of the LED's
// light (the ~70 % a grey reading loses), the red channel all of it. Each
// LED's brightest pixel (its `_peak` column) less the background: red's
// over grey's 1 / 0.299 = 3.34 within 10 % (the same pixel in both, 1 level
// of noise against 54 of signal in grey; MJPEG's error on the peak, a few
// levels: measured 2 % on this video).
TEST(VideoColour, ARedLedInAColourVideoFileIsReadInItsRedChannel) {
  const std::string dir = test::ScratchDir("video_colour_file");
  Shot s;
  s.rate_hz = 100;
  constexpr int kN = 60;
  const test::TestCamera cam;
  const std::string video = dir + "/red.avi";
  {
    test::TestVideoWriter w = test::TestVideoWriter::Colour(video, cam.width, cam.height, 100, 2);
    cv::RNG rng(35);
    for (int k = 0; k < kN; ++k) {
      // The LEDs light the red channel only; each channel has its own noise.
      const cv::Mat red = RenderFrame(cam, s, k, rng);  // background, LEDs and noise, 8-bit
      cv::Mat dark_light(cam.height, cam.width, CV_64F, cv::Scalar(kBackgroundLevel));
      const cv::Mat green = test::SensorFrame(dark_light, kPixelNoise, rng);
      const cv::Mat blue = test::SensorFrame(dark_light, kPixelNoise, rng);
      cv::Mat bgr;
      cv::merge(std::vector<cv::Mat>{blue, green, red}, bgr);
      w.Write(bgr, k * 10);
    }
    w.Close();
  }
  // Each LED's peak over the frames (columns after the 8 coordinates: area,
  // peak, flags per LED), and theta against the truth.
  const auto read = [&](const std::string& channel_key, const char* name) {
    const std::string sub = dir + "/" + name;
    std::filesystem::create_directories(sub);
    const ShotRun r = ReadShot(sub, RigFor(cam, 100, channel_key), video, s);
    return r;
  };
  const auto peaks = [&](const std::string& channel_key, const char* name, double* mean_signal) {
    const std::string sub = dir + "/" + name;
    std::filesystem::create_directories(sub);
    std::ofstream(sub + "/rig.toml") << RigFor(cam, 100, channel_key);
    RegisterSources();
    const daq::RigConfig rig = daq::LoadRigConfig(sub + "/rig.toml");
    daq::SourceOptions options;
    options.rig = &rig;
    std::unique_ptr<daq::Source> source = daq::OpenSource("video:" + video, options);
    daq::Frame frame;
    double sum = 0;
    int n = 0, frames = 0;
    while (source->Next(frame) == daq::ReadStatus::kFrame) {
      ++frames;
      for (int i = 0; i < 4; ++i) {
        const double peak = frame.values[static_cast<std::size_t>(8 + 3 * i + 1)];
        if (std::isfinite(peak)) sum += peak - kBackgroundLevel, ++n;
      }
    }
    *mean_signal = n > 0 ? sum / n : NAN;
    return frames;
  };
  double red_signal = 0, grey_signal = 0;
  EXPECT_EQ(peaks("channel = \"red\"\n", "red", &red_signal), kN);
  EXPECT_EQ(peaks("", "grey", &grey_signal), kN);
  std::printf("red LED, colour MJPEG AVI: mean peak signal %.1f levels in red, %.1f in grey (ratio %.3f; 1/0.299 = "
              "%.3f)\n",
              red_signal, grey_signal, red_signal / grey_signal, 1 / 0.299);
  EXPECT_NEAR(red_signal / grey_signal, 1 / 0.299, 0.1 / 0.299);
  // And every frame is tracked in red.
  const ShotRun on_red = read("channel = \"red\"\n", "red_run");
  EXPECT_EQ(on_red.compared, kN);
}

}  // namespace
}  // namespace rocklab::video::timing
