// A rocking block filmed by the test's own camera (test_video.h): theta(t)
// known, four LEDs drawn as blurred Gaussian spots through a distorting
// lens, sensor noise, 8-bit quantisation, motion blur over the exposure,
// one LED occluded for a while, one LED bright enough to clip, one frame
// dropped from the container's times. Written lossless (FFV1) and lossy
// (MJPEG), read back through `video:` and reconstructed by the DAQ.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "daq/processor.h"
#include "daq/rig_config.h"
#include "daq/source.h"
#include "tests/scratch.h"
#include "tests/video/test_video.h"
#include "video/frame_reader.h"
#include "video/video_source.h"

namespace rocklab::video {
namespace {

// The scene.
constexpr int kFps = 100;
constexpr int kFrames = 300;              // 3 s
constexpr double kExposureS = 0.004;      // motion blur: the spot is averaged over this
constexpr int kBlurSteps = 8;             // sub-exposure positions drawn
constexpr double kSpotSigmaPx = 1.2;      // LED spot, px
constexpr double kPeak = 180;             // spot peak, 8-bit levels (LED D: kBrightPeak)
constexpr double kBrightPeak = 340;       // clips at 255: a saturated LED
constexpr double kBackground = 12;        // 8-bit level
constexpr double kNoiseSigma = 2.0;       // sensor noise, 8-bit levels
constexpr double kThreshold = 40;         // [camera.video] threshold
constexpr int kMarginPx = 3;              // DetectorOptions::margin_px (its default)
constexpr int kOccludedFrom = 120, kOccludedTo = 150;  // LED B hidden in [from, to)
constexpr int kDroppedFrame = 200;
constexpr double kHalfWidth = 0.125;      // block 0.25 m x 1.0 m

struct Led {
  const char* name;
  double x, z;
  double peak;
};
const Led kLeds[] = {{"A", -0.08, 0.15, kPeak}, {"B", 0.08, 0.15, kPeak}, {"C", -0.08, 0.55, kPeak},
                     {"D", 0.08, 0.55, kBrightPeak}};

double Theta(double t) { return 0.05 * std::sin(2 * M_PI * 1.2 * t) * std::exp(-t / 2.0); }

// An LED's rig-plane position at theta: rocking about the corner on theta's side.
cv::Point2d Rocked(const Led& led, double theta) {
  const double px = theta >= 0 ? kHalfWidth : -kHalfWidth;
  const double c = std::cos(-theta), s = std::sin(-theta);  // theta > 0: clockwise in (x, z)
  const double dx = led.x - px, dz = led.z;
  return {px + c * dx - s * dz, s * dx + c * dz};
}

test::TestCamera Camera() {
  test::TestCamera cam;
  cam.k1 = -0.15;
  cam.k2 = 0.05;
  cam.yaw_rad = 0.1;
  return cam;
}

cv::Mat Render(const test::TestCamera& cam, int k, std::mt19937& rng) {
  cv::Mat light(cam.height, cam.width, CV_64F, cv::Scalar(kBackground));
  const double t = static_cast<double>(k) / kFps;
  for (const Led& led : kLeds) {
    if (led.name[0] == 'B' && k >= kOccludedFrom && k < kOccludedTo) continue;
    for (int s = 0; s < kBlurSteps; ++s) {
      const double ts = t + ((s + 0.5) / kBlurSteps - 0.5) * kExposureS;
      const cv::Point2d p = Rocked(led, Theta(ts));
      const cv::Point2d uv = cam.Project(p.x, p.y);
      const int r = static_cast<int>(std::ceil(5 * kSpotSigmaPx));
      for (int y = static_cast<int>(uv.y) - r; y <= static_cast<int>(uv.y) + r; ++y) {
        for (int x = static_cast<int>(uv.x) - r; x <= static_cast<int>(uv.x) + r; ++x) {
          if (x < 0 || y < 0 || x >= cam.width || y >= cam.height) continue;
          const double d2 = (x - uv.x) * (x - uv.x) + (y - uv.y) * (y - uv.y);
          light.at<double>(y, x) += led.peak / kBlurSteps * std::exp(-d2 / (2 * kSpotSigmaPx * kSpotSigmaPx));
        }
      }
    }
  }
  std::normal_distribution<double> noise(0.0, kNoiseSigma);
  cv::Mat out(cam.height, cam.width, CV_8U);
  for (int y = 0; y < cam.height; ++y) {
    for (int x = 0; x < cam.width; ++x) {
      out.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(std::lround(light.at<double>(y, x) + noise(rng)));
    }
  }
  return out;
}

std::string RigText(const test::TestCamera& cam) {
  std::ostringstream keys;
  keys.precision(10);
  keys << "threshold = " << kThreshold << "\nintrinsics = { fx_px = " << cam.fx << ", fy_px = " << cam.fy
       << ", cx_px = " << cam.cx << ", cy_px = " << cam.cy << ", distortion = [" << cam.k1 << ", " << cam.k2
       << ", 0, 0, 0] }\n";
  std::vector<test::RigLed> leds;
  for (const Led& led : kLeds) leds.push_back({led.name, led.x, led.z});
  // Reference marks: where the test's own projection puts six plane points.
  return test::VideoRigText(cam, kFps, leds, keys.str(),
                            {{{-0.3, 0.1}}, {{0.3, 0.1}}, {{-0.3, 0.6}}, {{0.3, 0.6}}, {{0.0, 0.35}}, {{-0.15, 0.45}}});
}

// Writes the scene's video (every frame but the dropped one) and the rig.
struct Scene {
  std::string dir, rig_path, video_path;
};
Scene MakeScene(const std::string& name, bool lossless) {
  Scene s;
  s.dir = test::ScratchDir(name);
  const test::TestCamera cam = Camera();
  s.rig_path = s.dir + "/rig.toml";
  std::ofstream(s.rig_path) << RigText(cam);
  s.video_path = s.dir + (lossless ? "/scene_ffv1.mkv" : "/scene_mjpg.mkv");
  test::TestVideoWriter w(s.video_path, lossless, cam.width, cam.height, kFps);
  std::mt19937 rng(2026);
  for (int k = 0; k < kFrames; ++k) {
    const cv::Mat frame = Render(cam, k, rng);
    if (k != kDroppedFrame) w.Write(frame, k * 1000 / kFps);
  }
  w.Close();
  return s;
}

// The theta noise the pixel noise allows. Oracle: the centroid's noise
// (test::CentroidSigmaPx) in metres by the plane scale at the LEDs, and the
// rigid fit's rotation has sigma_m / sqrt(S), S the LEDs' spread about
// their centroid (the 3 LEDs left during the occlusion: the worst).
struct NoiseBound {
  double sigma_px, sigma_theta;
};
NoiseBound ThetaSigma(double pixel_sigma) {
  const double sigma_px = test::CentroidSigmaPx(kSpotSigmaPx, kPeak, kThreshold, kBackground, kMarginPx, pixel_sigma);
  // Plane scale: the largest metres-per-pixel among the LEDs' places.
  const test::TestCamera cam = Camera();
  double m_per_px = 0;
  for (const Led& led : kLeds) {
    const cv::Point2d a = cam.Project(led.x, led.z), b = cam.Project(led.x + 1e-3, led.z),
                      c = cam.Project(led.x, led.z + 1e-3);
    m_per_px = std::max({m_per_px, 1e-3 / std::hypot(b.x - a.x, b.y - a.y), 1e-3 / std::hypot(c.x - a.x, c.y - a.y)});
  }
  // Spread of A, C, D (B occluded).
  const double cx = (kLeds[0].x + kLeds[2].x + kLeds[3].x) / 3, cz = (kLeds[0].z + kLeds[2].z + kLeds[3].z) / 3;
  double spread = 0;
  for (int i : {0, 2, 3}) spread += std::pow(kLeds[i].x - cx, 2) + std::pow(kLeds[i].z - cz, 2);
  return {sigma_px, sigma_px * m_per_px / std::sqrt(spread)};
}

struct Collect : daq::ProcessorSink {
  std::vector<daq::BlockState> states;
  void OnBlockState(const daq::BlockState& s) override { states.push_back(s); }
};

struct Result {
  double rms{}, max{};
  int compared{};
  daq::SequenceCounts seq;
  VideoStats stats;
};

Result Reconstruct(const Scene& s) {
  RegisterSources();
  const daq::RigConfig rig = daq::LoadRigConfig(s.rig_path);
  daq::SourceOptions options;
  options.sample_rate_hz = rig.sample_rate_hz;
  options.rig = &rig;
  std::unique_ptr<daq::Source> source = daq::OpenSource("video:" + s.video_path, options);
  Collect sink;
  daq::Processor processor(rig, source->channel_names(), source->path(), sink);
  daq::Frame frame;
  while (source->Next(frame) == daq::ReadStatus::kFrame) processor.Process(frame);
  processor.Finish();
  Result r;
  r.seq = processor.sequence();
  r.stats = *VideoStatsOf(*source);
  double sum2 = 0;
  for (const daq::BlockState& b : sink.states) {
    if (!std::isfinite(b.theta_camera)) continue;
    const double e = b.theta_camera - Theta(b.time_s);
    sum2 += e * e;
    r.max = std::max(r.max, std::abs(e));
    ++r.compared;
  }
  r.rms = r.compared > 0 ? std::sqrt(sum2 / r.compared) : NAN;
  return r;
}

void ExpectEventsCounted(const Result& r, bool lossless) {
  // Oracle: the scene's own schedule. One frame left out of the container:
  // one drop, seen by the reader and as one gap of one sample by the DAQ.
  EXPECT_EQ(r.stats.frames.frames, kFrames - 1);
  EXPECT_EQ(r.stats.frames.dropped, 1);
  EXPECT_EQ(r.stats.frames.drop_events, 1);
  EXPECT_EQ(r.stats.frames.repeated, 0);
  EXPECT_EQ(r.seq.gaps, 1);
  EXPECT_EQ(r.seq.missing, 1);
  EXPECT_FALSE(r.stats.times_from_fps);
  // LED B hidden for 30 frames: one occlusion, 30 missing samples, no other
  // LED lost, nothing taken for it.
  EXPECT_EQ(r.stats.track.occlusions, 1);
  EXPECT_EQ(r.stats.track.missing_samples, kOccludedTo - kOccludedFrom);
  EXPECT_EQ(r.stats.track.merged, 0);
  EXPECT_EQ(r.stats.track.ambiguous, 0);
  EXPECT_EQ(r.stats.track.inconsistent, 0);
  EXPECT_EQ(r.stats.track.reflections, 0);
  // LED D clips in every frame: measured and flagged each time (MJPEG's
  // ringing lowers some clipped peaks below 255: most frames there).
  if (lossless) {
    EXPECT_EQ(r.stats.track.saturated, kFrames - 1);
  } else {
    EXPECT_GT(r.stats.track.saturated, 0.8 * (kFrames - 1));
  }
  EXPECT_EQ(r.stats.track.fits, kFrames - 1);
}

TEST(VideoTracking, LosslessVideoGivesThetaWithinThePixelNoiseBound) {
  const Scene s = MakeScene("video_ffv1", true);
  const Result r = Reconstruct(s);
  const NoiseBound n = ThetaSigma(kNoiseSigma);
  // Oracle: Theta(t), the scene's truth. Bound: 5 sigma of the pixel noise
  // (ThetaSigma; 299 samples stay within 5 sigma) plus 0.02 px of centroid
  // bias (pixel-locking in a box of +-4 spot sigmas, undistortion) turned
  // into theta the same way; the RMS within 2 sigma (a bias would show).
  const double bias = 0.02 / n.sigma_px * n.sigma_theta;
  std::printf("FFV1: sigma_centroid %.4f px, sigma_theta %.3g rad; theta error RMS %.3g rad, max %.3g rad over %d "
              "samples\n",
              n.sigma_px, n.sigma_theta, r.rms, r.max, r.compared);
  EXPECT_EQ(r.compared, kFrames - 1);
  EXPECT_LT(r.max, 5 * n.sigma_theta + bias);
  EXPECT_LT(r.rms, 2 * n.sigma_theta);
  ExpectEventsCounted(r, true);
  // Six marks mapped by the true lens: the homography passes through them.
  EXPECT_LT(r.stats.mark_rms_m, 1e-5);
}

TEST(VideoTracking, MjpegVideoGivesThetaWithinTheBoundOfItsMeasuredPixelError) {
  const Scene s = MakeScene("video_mjpg", false);
  // The compression's pixel error, measured by the test: its own frames
  // against OpenCV's decoding of the file (the same frames, the same seed).
  cv::VideoCapture cap(s.video_path, cv::CAP_FFMPEG);
  ASSERT_TRUE(cap.isOpened());
  std::mt19937 rng(2026);
  const test::TestCamera cam = Camera();
  double sum2 = 0;
  long n_px = 0;
  cv::Mat decoded, gray;
  for (int k = 0; k < kFrames; ++k) {
    const cv::Mat truth = Render(cam, k, rng);
    if (k == kDroppedFrame) continue;
    if (k % 10 != 0) {
      cap.grab();
      continue;
    }
    ASSERT_TRUE(cap.read(decoded));
    cv::cvtColor(decoded, gray, cv::COLOR_BGR2GRAY);
    cv::Mat diff;
    cv::subtract(gray, truth, diff, cv::noArray(), CV_64F);
    sum2 += diff.dot(diff);
    n_px += diff.total();
  }
  const double jpeg_sigma = std::sqrt(sum2 / n_px);
  const Result r = Reconstruct(s);
  // Oracle: Theta(t). JPEG's error is neither white nor independent of the
  // signal: the bound takes the measured RMS pixel error (sensor noise
  // included) as if white, doubles it, and keeps the lossless case's
  // 5 sigma + 0.02 px bias.
  const NoiseBound n = ThetaSigma(2 * jpeg_sigma);
  const double bias = 0.02 / n.sigma_px * n.sigma_theta;
  std::printf("MJPEG: pixel error RMS %.3f levels; sigma_theta %.3g rad; theta error RMS %.3g rad, max %.3g rad "
              "over %d samples\n",
              jpeg_sigma, n.sigma_theta, r.rms, r.max, r.compared);
  EXPECT_EQ(r.compared, kFrames - 1);
  EXPECT_LT(r.max, 5 * n.sigma_theta + bias);
  ExpectEventsCounted(r, false);
}

}  // namespace
}  // namespace rocklab::video

namespace rocklab::video {
namespace {

std::string Slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The theta column of a reconstruct CSV.
std::vector<double> ThetaColumn(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  std::vector<double> out;
  while (std::getline(in, line)) {
    const std::size_t a = line.find(','), b = line.find(',', a + 1);
    out.push_back(std::strtod(line.substr(a + 1, b - a - 1).c_str(), nullptr));
  }
  return out;
}

TEST(VideoTracking, TrackCsvReconstructsLikeTheVideoInputThroughTheCli) {
  const Scene s = MakeScene("video_cli", true);
  const std::string raw = s.dir + "/raw.csv", from_raw = s.dir + "/theta_raw.csv", from_video = s.dir + "/theta_video.csv";
  const std::string bin = ROCKLAB_BINARY;
  ASSERT_EQ(std::system((bin + " track " + s.video_path + " --rig " + s.rig_path + " --out " + raw + " 2> " + s.dir +
                         "/track.err")
                            .c_str()),
            0)
      << Slurp(s.dir + "/track.err");
  ASSERT_EQ(std::system((bin + " reconstruct --rig " + s.rig_path + " --input " + raw + " --out " + from_raw + " 2> " +
                         s.dir + "/r1.err")
                            .c_str()),
            0)
      << Slurp(s.dir + "/r1.err");
  ASSERT_EQ(std::system((bin + " reconstruct --rig " + s.rig_path + " --input video:" + s.video_path + " --out " +
                         from_video + " 2> " + s.dir + "/r2.err")
                            .c_str()),
            0)
      << Slurp(s.dir + "/r2.err");
  // Oracle: the same frames through two paths. The CSV holds 10 significant
  // digits of each coordinate (1e-10 m at 0.5 m), so theta agrees to 1e-8 rad.
  const std::vector<double> a = ThetaColumn(from_raw), b = ThetaColumn(from_video);
  ASSERT_EQ(a.size(), b.size());
  ASSERT_GT(a.size(), 250u);
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (std::isnan(a[i])) {
      EXPECT_TRUE(std::isnan(b[i])) << i;
    } else {
      EXPECT_NEAR(a[i], b[i], 1e-8) << i;
    }
  }
  // What track said: the drop, the occlusion and the clipped LED, counted.
  const std::string err = Slurp(s.dir + "/track.err");
  EXPECT_NE(err.find("299 frames tracked"), std::string::npos) << err;
  EXPECT_NE(err.find("1 dropped in 1 places"), std::string::npos) << err;
  EXPECT_NE(err.find("30 missing (1 occlusions)"), std::string::npos) << err;
  EXPECT_NE(err.find("1 frame(s) dropped before this one"), std::string::npos) << err;
  // The raw CSV's header: the rig's LED channels, then the quality columns.
  std::ifstream in(raw);
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header.rfind("time,side_A_x,side_A_z,side_B_x,side_B_z,side_C_x,side_C_z,side_D_x,side_D_z,"
                         "side_A_area_px,side_A_peak,side_A_flags,",
                         0),
            0u)
      << header;
}

TEST(VideoTracking, ImageSequenceTakesItsTimesFromTheRigsFpsAndSaysSo) {
  const std::string dir = test::ScratchDir("video_png");
  const test::TestCamera cam = Camera();
  std::filesystem::create_directories(dir + "/frames");
  std::mt19937 rng(2026);
  constexpr int kPngFrames = 60;
  for (int k = 0; k < kPngFrames; ++k) {
    char name[64];
    std::snprintf(name, sizeof name, "/frames/%06d.png", k);
    cv::imwrite(dir + name, Render(cam, k, rng));
  }
  std::string rig = RigText(cam);
  rig.insert(rig.find("threshold"), "fps = 100.0\n");
  std::ofstream(dir + "/rig.toml") << rig;
  const Result r = Reconstruct(Scene{dir, dir + "/rig.toml", dir + "/frames/%06d.png"});
  const NoiseBound n = ThetaSigma(kNoiseSigma);
  // Oracle: Theta(t) at t = index / 100 Hz; the lossless case's bound.
  EXPECT_TRUE(r.stats.times_from_fps);
  EXPECT_NE(r.stats.rate_source.find("image sequence has no timestamps"), std::string::npos) << r.stats.rate_source;
  EXPECT_EQ(r.stats.frames.frames, kPngFrames);
  EXPECT_EQ(r.stats.frames.dropped, 0);
  EXPECT_EQ(r.compared, kPngFrames);
  EXPECT_LT(r.max, 5 * n.sigma_theta + 0.02 / n.sigma_px * n.sigma_theta);
}

TEST(VideoTracking, ImageSequenceWithoutFpsIsAStartUpErrorNamingTheKey) {
  const std::string dir = test::ScratchDir("video_png_nofps");
  std::filesystem::create_directories(dir + "/frames");
  std::mt19937 rng(1);
  cv::imwrite(dir + "/frames/000000.png", Render(Camera(), 0, rng));
  std::ofstream(dir + "/rig.toml") << RigText(Camera());
  RegisterSources();
  const daq::RigConfig rig = daq::LoadRigConfig(dir + "/rig.toml");
  daq::SourceOptions options;
  options.rig = &rig;
  try {
    (void)daq::OpenSource("video:" + dir + "/frames/%06d.png", options);
    ADD_FAILURE() << "opened";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("set [camera.video] fps"), std::string::npos) << e.what();
  }
}

// Oracle for the rig errors: the file the test wrote, its line numbers.
std::string OpenError(const std::string& name, const std::string& rig_text, const std::string& input) {
  return test::VideoOpenError(name, rig_text, input);
}

TEST(VideoConfigErrors, NameTheFileLineAndKey) {
  const std::string good = RigText(Camera());
  // A misspelt key: unknown keys are errors, with their line.
  std::string typo = good;
  typo.replace(typo.find("threshold"), 9, "treshold");
  const int typo_line = 1 + static_cast<int>(std::count(typo.begin(), typo.begin() + typo.find("treshold"), '\n'));
  const std::string e1 = OpenError("video_cfg_typo", typo, "");
  EXPECT_NE(e1.find("rig.toml:" + std::to_string(typo_line) + ": key 'camera.video.treshold' is not a video key"),
            std::string::npos)
      << e1;
  // Three marks do not make a homography.
  std::string three = good;
  for (int i = 0; i < 3; ++i) {
    const std::size_t at = three.find("  { u_px");
    three.erase(at, three.find('\n', at) - at + 1);
  }
  const std::string e2 = OpenError("video_cfg_marks", three, "");
  EXPECT_NE(e2.find("key 'camera.video.mark' must list at least 4 reference marks"), std::string::npos) << e2;
  // No [camera.video] at all.
  std::string none = good;
  none.erase(none.find("[camera.video]"), none.find("[[channel]]") - none.find("[camera.video]"));
  const std::string e3 = OpenError("video_cfg_none", none, "");
  EXPECT_NE(e3.find("no [camera.video] section"), std::string::npos) << e3;
  // A video that is not there.
  const std::string e4 = OpenError("video_cfg_file", good, "");
  EXPECT_NE(e4.find("none.mkv: cannot be opened as a video"), std::string::npos) << e4;
  // A V4L2 device that is not there.
  const std::string e6 = OpenError("video_cfg_v4l2", good, "v4l2:" + test::ScratchDir("video_cfg_v4l2") + "/video9");
  EXPECT_NE(e6.find("video9: cannot be opened as a video device (V4L2)"), std::string::npos) << e6;
  // A threshold out of range.
  std::string high = good;
  high.replace(high.find("threshold = 40"), 14, "threshold = 300");
  const std::string e5 = OpenError("video_cfg_range", high, "");
  EXPECT_NE(e5.find("key 'camera.video.threshold' must be in [1, 254] (is 300)"), std::string::npos) << e5;
}

}  // namespace
}  // namespace rocklab::video

namespace rocklab::video {
namespace {

// Frames at the times the test gives the container, read back by the
// FrameReader. Oracle: the times written.
FrameCounts ReadTimes(const std::string& name, const std::vector<int64_t>& pts_ms, std::vector<double>* times) {
  const std::string path = test::ScratchDir(name) + "/times.mkv";
  {
    test::TestVideoWriter w(path, true, 64, 48, kFps);
    cv::Mat f(48, 64, CV_8U, cv::Scalar(10));
    for (int64_t p : pts_ms) w.Write(f, p);
    w.Close();
  }
  FrameReader r(path, false, std::nullopt);
  cv::Mat gray;
  double t = 0;
  int64_t n = 0;
  while (r.Next(gray, t, n)) times->push_back(t);
  return r.counts();
}

TEST(FrameReader, RepeatedAndDroppedFramesAreCountedFromTheContainersTimes) {
  std::vector<double> times;
  // 0, 10, 20, 20 (a repeat), 30, 60 (two dropped), 70 ms at 100 frames/s.
  const FrameCounts c = ReadTimes("times_repeat", {0, 10, 20, 20, 30, 60, 70}, &times);
  EXPECT_EQ(c.repeated, 1);
  EXPECT_EQ(c.dropped, 2);
  EXPECT_EQ(c.drop_events, 1);
  EXPECT_EQ(c.frames, 6);
  ASSERT_EQ(times.size(), 6u);
  EXPECT_NEAR(times[4], 0.060, 1e-9);
}

TEST(FrameReader, AVideoWithoutTimesIsTimedByItsRateAndCounted) {
  std::vector<double> times;
  // Every frame at 0 ms: the container gives no times.
  const FrameCounts c = ReadTimes("times_none", {0, 0, 0, 0}, &times);
  EXPECT_EQ(c.frames, 4);
  EXPECT_EQ(c.untimed, 3);
  EXPECT_EQ(c.repeated, 0);
  ASSERT_EQ(times.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) EXPECT_NEAR(times[i], i / 100.0, 1e-12);
}

}  // namespace
}  // namespace rocklab::video
