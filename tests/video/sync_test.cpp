// In step with the DAQ (issue 35, item 2): a forced test filmed by a camera
// whose clock is offset and drifts against the DAQ's, a sync LED in view
// driven by a DAQ channel at irregular times. The test renders its own
// truth: the table's Hanning sine on the DAQ's clock, the block's rocking
// from Housner's model driven by it (model::Simulate), the LEDs blurred over
// each exposure and the sync LED lit for the share of the exposure its
// drive was on; the DAQ record (table displacement, acceleration, the
// drive) sampled at 2 kHz. `rocklab track --daq` must find the clocks,
// and the merged record must go through `reconstruct`, `run` and `fit`.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "model/excitation.h"
#include "model/rocking_model.h"
#include "tests/scratch.h"
#include "tests/video/test_video.h"
#include "video/daq_sync.h"

namespace rocklab::video::sync {
namespace {

constexpr double kFrameRate = 100;       // the camera's, on its own clock, frames/s
constexpr double kExposure = 0.010;      // a whole frame period (360 degree shutter), s
constexpr double kDaqRate = 2000;        // Hz
constexpr double kOffset = 0.137;        // DAQ time of the video's time 0, s
constexpr double kDriftPpm = 300;        // the DAQ's clock runs 1 + 300e-6 times the camera's
constexpr int kFrames = 400;             // 4 s of video
constexpr double kDaqSpan = 4.5;         // s of DAQ record
constexpr double kSpotPx = 1.2, kLedPeak = 180, kBackground = 12, kNoise = 1.0, kThreshold = 40;
constexpr double kSyncSigmaPx = 2.0, kSyncPeak = 100;  // unclipped: its light is linear in its on time
constexpr int kSyncRadius = 4;
const cv::Point2d kSyncAt(192, 110);
constexpr double kHalfWidth = 0.125;      // the rig's block: 0.25 x 1.0 m

struct SyncLayoutLed {
  const char* name;
  double x, z;
};
const SyncLayoutLed kSyncLayout[] = {{"A", -0.08, 0.15}, {"B", 0.08, 0.15}, {"C", -0.08, 0.55}, {"D", 0.08, 0.55}};

test::TestCamera SyncCamera() {
  test::TestCamera cam;
  cam.width = 200;
  cam.height = 220;
  cam.cx = 100;
  cam.cy = 110;
  return cam;
}

// The truth, on the DAQ's clock.
struct Truth {
  std::unique_ptr<model::Excitation> table;
  model::Trajectory run;      // theta at 4 kHz
  std::vector<double> toggles;  // the drive's switches, s (off before the first)
  double Theta(double t) const {
    const double h = run.time_s[1] - run.time_s[0];
    const double x = std::clamp(t / h, 0.0, static_cast<double>(run.time_s.size() - 2));
    const std::size_t i = static_cast<std::size_t>(x);
    return run.theta[i] + (x - i) * (run.theta[i + 1] - run.theta[i]);
  }
  bool On(double t) const {
    return (std::upper_bound(toggles.begin(), toggles.end(), t) - toggles.begin()) % 2 == 1;
  }
  // The share of [a, b] the drive was on.
  double OnShare(double a, double b) const {
    double on = 0, from = a;
    for (auto it = std::upper_bound(toggles.begin(), toggles.end(), a); it != toggles.end() && *it < b; ++it) {
      if (On(0.5 * (from + *it))) on += *it - from;
      from = *it;
    }
    if (On(0.5 * (from + b))) on += b - from;
    return on / (b - a);
  }
};

// The rig's block from its geometry (docs/models.md): alpha = atan(b / h),
// p = sqrt(3 g / (4 R)), mu = 1 - 1.5 sin^2 alpha.
model::BlockParams TruthParams() {
  model::BlockParams b;
  b.alpha = std::atan(0.25);
  b.p = std::sqrt(3 * 9.81 / (4 * std::hypot(0.125, 0.5)));
  b.mu = 1 - 1.5 * std::pow(std::sin(b.alpha), 2);
  return b;
}

Truth MakeTruth() {
  Truth t;
  model::SineSpec sine;
  sine.amplitude_m = 0.008;  // peak 3.4 m/s^2 against the uplift's g tan(alpha) = 2.45
  sine.frequency_hz = 3.3;
  sine.duration_s = 3.0;
  sine.start_s = 0.4;
  t.table = model::MakeHanningSine(sine);
  auto m = model::RockingModel::Create(model::ModelKind::kHousner, TruthParams());
  t.run = model::Simulate(*m, *t.table, 0.0, 0.0, 0.0, kDaqSpan + 0.1, 4000);
  // Irregular switching (a fixed LCG): 0.03 to 0.10 s apart, never periodic.
  uint32_t s = 35;
  for (double at = 0.1; at < kDaqSpan; at += 0.03 + 0.07 * ((s = s * 1664525u + 1013904223u) >> 8) / 16777216.0) {
    t.toggles.push_back(at);
  }
  return t;
}

double DaqTime(double t_video) { return kOffset + (1 + 1e-6 * kDriftPpm) * t_video; }

// An LED on the rig plane: the block turned by theta about its corner on
// the side it leans to, carried by the table.
cv::Point2d SyncPlaneAt(const SyncLayoutLed& led, double theta, double table_m) {
  const double corner = theta >= 0 ? kHalfWidth : -kHalfWidth;
  const double c = std::cos(theta), s = std::sin(theta), dx = led.x - corner;
  return {table_m + corner + c * dx + s * led.z, -s * dx + c * led.z};
}

void AddSyncSpot(cv::Mat& light, const cv::Point2d& uv, double sigma, double peak) {
  const int r = static_cast<int>(std::ceil(5 * sigma));
  for (int y = static_cast<int>(uv.y) - r; y <= static_cast<int>(uv.y) + r; ++y) {
    for (int x = static_cast<int>(uv.x) - r; x <= static_cast<int>(uv.x) + r; ++x) {
      if (x < 0 || y < 0 || x >= light.cols || y >= light.rows) continue;
      light.at<double>(y, x) += peak * std::exp(-((x - uv.x) * (x - uv.x) + (y - uv.y) * (y - uv.y)) / (2 * sigma * sigma));
    }
  }
}

const std::vector<std::array<double, 2>> kSyncMarks = {{-0.2, 0.12}, {0.2, 0.12}, {-0.2, 0.58},
                                                       {0.2, 0.58},  {0.0, 0.35}, {-0.1, 0.45}};

struct Shot {
  std::string dir, video, daq;
  std::string rig_camera;  // sample_rate_hz: the camera's
  std::string rig_table;   // the same, sync = "table"
};

Shot WriteForcedShot(const Truth& truth, const std::string& name) {
  Shot s;
  s.dir = test::ScratchDir(name);
  const test::TestCamera cam = SyncCamera();
  // The video: frame k exposed over video times [k / rate, k / rate + E].
  s.video = s.dir + "/shot.mkv";
  test::TestVideoWriter w(s.video, true, cam.width, cam.height, static_cast<int>(kFrameRate));
  cv::RNG rng(35);
  constexpr int kBlurSteps = 4;
  for (int k = 0; k < kFrames; ++k) {
    cv::Mat light(cam.height, cam.width, CV_64F, cv::Scalar(kBackground));
    const double tv = k / kFrameRate;
    for (int b = 0; b < kBlurSteps; ++b) {
      const double t = DaqTime(tv + (b + 0.5) / kBlurSteps * kExposure);
      for (const SyncLayoutLed& led : kSyncLayout) {
        const cv::Point2d p = SyncPlaneAt(led, truth.Theta(t), truth.table->Displacement(t));
        AddSyncSpot(light, cam.Project(p.x, p.y), kSpotPx, kLedPeak / kBlurSteps);
      }
    }
    AddSyncSpot(light, kSyncAt, kSyncSigmaPx, kSyncPeak * truth.OnShare(DaqTime(tv), DaqTime(tv + kExposure)));
    w.Write(test::SensorFrame(light, kNoise, rng), std::llround(k * 1000.0 / kFrameRate));
  }
  w.Close();
  // The DAQ's record: the table's displacement and acceleration, the drive (V).
  s.daq = s.dir + "/daq.csv";
  std::ofstream d(s.daq);
  d << "time,table_disp,table_acc,sync_out\n";
  d.precision(12);
  for (int i = 0; i < static_cast<int>(kDaqSpan * kDaqRate); ++i) {
    const double t = i / kDaqRate;
    d << t << "," << truth.table->Displacement(t) << "," << truth.table->TableAcceleration(t) << ","
      << (truth.On(t) ? 5.0 : 0.0) << "\n";
  }
  d.close();
  std::vector<test::RigLed> leds;
  for (const SyncLayoutLed& led : kSyncLayout) leds.push_back({led.name, led.x, led.z});
  std::ostringstream keys;
  keys << "threshold = " << kThreshold << "\nexposure_s = " << kExposure << "\nfps = " << kFrameRate
       << "\nroi_px = [0, 0, 180, 220]\nsync = \"led\"\nsync_led_px = [" << kSyncAt.x << ", " << kSyncAt.y
       << "]\nsync_radius_px = " << kSyncRadius << "\nsync_channel = \"sync_out\"\n";
  // The rig's sample_rate_hz is the camera's: the merged record's rate.
  std::string rig = test::VideoRigText(cam, kFrameRate, leds, keys.str(), kSyncMarks);
  rig += "[[channel]]\nname = \"table_disp\"\nsensor = \"table.displacement\"\nunit = \"m\"\ngain = 1.0\n"
         "[[channel]]\nname = \"table_acc\"\nsensor = \"table.acceleration\"\nunit = \"m/s^2\"\ngain = 1.0\n";
  s.rig_camera = s.dir + "/rig.toml";
  std::ofstream(s.rig_camera) << rig;
  // The same rig synced by the table's motion: no LED, the DAQ's table
  // displacement against the block's pivot seen in the video.
  std::string by_table = rig;
  const std::string led_keys = "sync = \"led\"";
  by_table.replace(by_table.find(led_keys), rig.find("sync_channel") - rig.find(led_keys),
                   "sync = \"table\"\n");
  const std::string drive_key = "sync_channel = \"sync_out\"";
  by_table.replace(by_table.find(drive_key), drive_key.size(), "sync_channel = \"table_disp\"");
  s.rig_table = s.dir + "/rig_table.toml";
  std::ofstream(s.rig_table) << by_table;
  return s;
}

std::string SyncSlurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

int SyncRun(const std::string& command, const std::string& out, const std::string& err) {
  return std::system((command + " > " + out + " 2> " + err).c_str());
}

// The a-priori standard errors of the clock fit from the edges the test
// switched inside the video. Oracle: each paired edge is off by
// independent errors: the DAQ's crossing, between two samples, uniform
// over 1 / rate (variance Td^2 / 12); the video's from the frame that saw
// the switch, whose light (linear in the on time, unclipped) places it to
// E x the level's noise / the contrast, except when it falls within the 3 %
// settled band at either end of a frame, then placed at the frame's edge:
// uniform over 0.06 E; a 360 degree shutter leaves no dark time between
// frames. The least-squares line's errors follow (sigma sqrt(1/n +
// xbar^2 / Sxx) at t = 0, sigma / sqrt(Sxx) for the slope).
void SyncApriori(const Truth& truth, double* se_offset, double* se_drift) {
  const double contrast = kSyncPeak * 2 * M_PI * kSyncSigmaPx * kSyncSigmaPx /
                          std::pow(2 * kSyncRadius + 1, 2);  // the window's mean, nearly all the spot's light
  const double level_noise = std::sqrt(kNoise * kNoise + 1.0 / 12) / (2 * kSyncRadius + 1);
  const double var = 1 / (12 * kDaqRate * kDaqRate) + std::pow(0.06 * kExposure, 2) / 12 +
                     std::pow(kExposure * level_noise / contrast, 2);
  std::vector<double> x;
  for (double t : truth.toggles) {
    const double tv = (t - kOffset) / (1 + 1e-6 * kDriftPpm);
    if (tv > 0.02 && tv < (kFrames - 2) / kFrameRate) x.push_back(tv);
  }
  double xm = 0, sxx = 0;
  for (double v : x) xm += v / x.size();
  for (double v : x) sxx += (v - xm) * (v - xm);
  *se_offset = std::sqrt(var * (1.0 / x.size() + xm * xm / sxx));
  *se_drift = std::sqrt(var / sxx);
}

TEST(VideoSync, AForcedTestIsMergedOnTheDaqClockAndFitted) {
  const Truth truth = MakeTruth();
  double peak = 0;
  for (double th : truth.run.theta) peak = std::max(peak, std::abs(th));
  ASSERT_GT(peak, 0.005) << "the table must rock the block";
  ASSERT_LT(peak, 0.1);
  const Shot s = WriteForcedShot(truth, "video_sync_forced");
  const std::string bin = ROCKLAB_BINARY;
  // The rig's sample_rate_hz is the camera's: the merged record is a grid
  // at 100 Hz on the DAQ's clock, the table's channels as their least-squares chord.
  const std::string merged = s.dir + "/merged.csv";
  ASSERT_EQ(SyncRun(bin + " track " + s.video + " --rig " + s.rig_camera + " --daq " + s.daq + " --out " + merged +
                        " --json",
                    s.dir + "/track.json", s.dir + "/track.err"),
            0)
      << SyncSlurp(s.dir + "/track.err");
  const nlohmann::json j = nlohmann::json::parse(SyncSlurp(s.dir + "/track.json"));
  const nlohmann::json& sy = j.at("sync");
  // On the camera's grid the merge says how its table values are fitted.
  EXPECT_NE(SyncSlurp(s.dir + "/track.err").find("--table chord"), std::string::npos)
      << SyncSlurp(s.dir + "/track.err");
  double se_offset = 0, se_drift = 0;
  SyncApriori(truth, &se_offset, &se_drift);
  // 4 standard errors of the a-priori fit.
  EXPECT_NEAR(sy.at("offset_s").get<double>(), kOffset, 4 * se_offset) << sy.dump();
  EXPECT_NEAR(sy.at("drift_ppm").get<double>(), kDriftPpm, 4e6 * se_drift) << sy.dump();
  EXPECT_LT(4e6 * se_drift, kDriftPpm);  // the drift is resolved: 0 is outside the bound
  // Every edge the video saw paired; the residuals within what the periods allow.
  EXPECT_EQ(sy.at("edges_paired").get<int>(), sy.at("edges_video").get<int>());
  EXPECT_LT(sy.at("residual_max_s").get<double>(), 1 / kDaqRate + 0.06 * kExposure);
  std::printf("sync: offset %.7f s (se %.2g), drift %.2f ppm (se %.3g), %d edges paired, residual rms %.3g ms; "
              "a-priori se %.2g s, %.3g ppm\n",
              sy.at("offset_s").get<double>(), sy.at("offset_se_s").get<double>(), sy.at("drift_ppm").get<double>(),
              sy.at("drift_se_ppm").get<double>(), sy.at("edges_paired").get<int>(),
              1e3 * sy.at("residual_rms_s").get<double>(), se_offset, 1e6 * se_drift);
  // The merged record: the DAQ's columns, then the video's; the grid spans
  // the 399 frame periods of the video's clock, 1 + drift longer on the DAQ's.
  std::ifstream in(merged);
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header.rfind("time,table_disp,table_acc,sync_out,side_A_x,", 0), 0u) << header;
  EXPECT_NE(header.find(",side_sync_level"), std::string::npos) << header;
  EXPECT_EQ(j.at("rows").get<int>(), static_cast<int>(std::floor((kFrames - 1) * (1 + 1e-6 * kDriftPpm))) + 1);
  // DAQ samples before the first frame's time (mid-exposure, E / 2 on the video's clock).
  EXPECT_NEAR(sy.at("rows_before").get<int>(), std::ceil(DaqTime(0.5 * kExposure) * kDaqRate), 1);

  // The same video synced by the table's motion instead (sync = "table":
  // the pivot corner of the LEDs' rigid fit against the DAQ's table
  // displacement). Oracle: the clock the shot was rendered with, within 4
  // a-priori standard errors of a least-squares time shift, sigma_x /
  // sqrt(sum x'(t)^2) over the frames for the offset (and sigma_x /
  // sqrt(sum (t - tbar)^2 x'(t)^2) for the drift), x' the truth's table
  // velocity and sigma_x the pivot's noise: the centroid noise through the
  // rigid fit, the translation's (sigma_c / 2 with 4 LEDs) and theta's
  // (sigma_c / sqrt(S)) times the 0.35 m from the LEDs' centre down to
  // the pivot. The reported standard errors within a factor 2 of those.
  {
    const std::string merged_table = s.dir + "/merged_table.csv";
    ASSERT_EQ(SyncRun(bin + " track " + s.video + " --rig " + s.rig_table + " --daq " + s.daq + " --out " +
                          merged_table + " --json",
                      s.dir + "/track_table.json", s.dir + "/track_table.err"),
              0)
        << SyncSlurp(s.dir + "/track_table.err");
    const nlohmann::json jt = nlohmann::json::parse(SyncSlurp(s.dir + "/track_table.json")).at("sync");
    EXPECT_EQ(jt.at("method").get<std::string>(), "table");
    const double sigma_c = test::CentroidSigmaPx(kSpotPx, kLedPeak, kThreshold, kBackground, 3, kNoise) * 2.5e-3;
    const double sigma_x = std::hypot(sigma_c / 2, 0.35 * sigma_c / std::sqrt(0.186));
    double tbar = 0, n_frames = 0;
    for (int k = 0; k < kFrames; ++k) tbar += (k + 0.5) / kFrameRate, ++n_frames;
    tbar /= n_frames;
    double sv = 0, svt = 0;
    for (int k = 0; k < kFrames; ++k) {
      const double tv = (k + 0.5) / kFrameRate;
      const double v = truth.table->Velocity(DaqTime(tv));
      sv += v * v;
      svt += (tv - tbar) * (tv - tbar) * v * v;
    }
    const double se_c = sigma_x / std::sqrt(sv), se_d = sigma_x / std::sqrt(svt);
    // The offset at the video's time 0 carries the drift's error times tbar.
    const double se_c0 = std::hypot(se_c, tbar * se_d);
    EXPECT_NEAR(jt.at("offset_s").get<double>(), kOffset, 4 * se_c0) << jt.dump();
    EXPECT_NEAR(jt.at("drift_ppm").get<double>(), kDriftPpm, 4e6 * se_d) << jt.dump();
    EXPECT_GT(jt.at("correlation").get<double>(), 0.99);
    EXPECT_LT(jt.at("offset_se_s").get<double>(), 2 * se_c0);
    EXPECT_GT(jt.at("offset_se_s").get<double>(), 0.5 * se_c0);
    std::ifstream tin(merged_table);
    std::string theader;
    std::getline(tin, theader);
    EXPECT_EQ(theader.find("_sync_level"), std::string::npos) << theader;
    std::printf("sync by the table: offset %.7f s (se %.2g; a-priori %.2g), drift %.1f ppm (se %.3g; a-priori %.3g), "
                "correlation %.5f, residual %.3g mm\n",
                jt.at("offset_s").get<double>(), jt.at("offset_se_s").get<double>(), se_c0,
                jt.at("drift_ppm").get<double>(), jt.at("drift_se_ppm").get<double>(), 1e6 * se_d,
                jt.at("correlation").get<double>(), 1e3 * jt.at("motion_residual_m").get<double>());
  }

  // Through reconstruct: theta on the DAQ's clock against the truth there.
  const std::string theta = s.dir + "/theta.csv";
  ASSERT_EQ(SyncRun(bin + " reconstruct --rig " + s.rig_camera + " --input " + merged + " --out " + theta,
                    s.dir + "/r.out", s.dir + "/r.err"),
            0)
      << SyncSlurp(s.dir + "/r.err");
  std::ifstream th(theta);
  std::string line;
  std::getline(th, line);
  double worst = 0, sum2 = 0;
  int n = 0;
  while (std::getline(th, line)) {
    const std::size_t a = line.find(','), b = line.find(',', a + 1);
    const double t = std::strtod(line.substr(0, a).c_str(), nullptr);
    const double v = std::strtod(line.substr(a + 1, b - a - 1).c_str(), nullptr);
    if (!std::isfinite(v)) continue;
    // Within two frames of an impact the chord between frames spans the
    // jump of theta_dot (docs/video.md, "In step with the DAQ", 5).
    bool near_impact = false;
    for (const model::ModelEvent& ev : truth.run.events) {
      near_impact = near_impact || (ev.kind == model::EventKind::kImpact && std::abs(t - ev.time_s) < 2 / kFrameRate);
    }
    if (near_impact) continue;
    const double e = v - truth.Theta(t);
    worst = std::max(worst, std::abs(e));
    sum2 += e * e;
    ++n;
  }
  ASSERT_GT(n, 250);  // of 400: those near the impacts left out
  // Oracle: the centroid noise (test::CentroidSigmaPx, 0.060 px at 2.5 mm/px
  // over the LEDs' spread of 0.186 m^2: 3.5e-4 rad, 5 sigma 1.7e-3) plus
  // the timing error, max |theta'| x 4 a-priori standard errors of the
  // offset and of the drift over the 4 s, plus the chord between frames,
  // max |theta''| T^2 / 8 (theta'' from the truth's theta_dot).
  const double sigma_theta = test::CentroidSigmaPx(kSpotPx, kLedPeak, kThreshold, kBackground, 3, kNoise) * 2.5e-3 /
                             std::sqrt(0.186);
  double rate_max = 0, accel_max = 0;
  for (std::size_t i = 1; i < truth.run.theta_dot.size(); ++i) {
    rate_max = std::max(rate_max, std::abs(truth.run.theta_dot[i]));
    const double a = (truth.run.theta_dot[i] - truth.run.theta_dot[i - 1]) * 4000;
    if (std::abs(a) < 100) accel_max = std::max(accel_max, std::abs(a));  // not across an impact
  }
  const double bound = 5 * sigma_theta + rate_max * 4 * (se_offset + 4 * se_drift) +
                       accel_max / (8 * kFrameRate * kFrameRate);
  EXPECT_LT(worst, bound) << "rms " << std::sqrt(sum2 / n);
  std::printf("theta on the DAQ clock: error rms %.3g, max %.3g rad (bound %.3g) over %d samples\n",
              std::sqrt(sum2 / n), worst, bound, n);

  // Through run (DAQ, models, comparison) into a log, and fit's trajectory
  // method on it (from the geometry's start only: --starts 0): the block's
  // parameters the truth was simulated with. --table chord: the merge's
  // least-squares chord values are meant to be read as the chord (fit's
  // default, the spline, is for point samples; docs/video.md).
  const std::string log = s.dir + "/test.lcm";
  ASSERT_EQ(SyncRun(bin + " run --rig " + s.rig_camera + " --input " + merged + " --max --log " + log,
                    s.dir + "/run.out", s.dir + "/run.err"),
            0)
      << SyncSlurp(s.dir + "/run.err");
  ASSERT_EQ(SyncRun(bin + " fit " + log + " --rig " + s.rig_camera + " --method trajectory --starts 0 --table chord --json",
                    s.dir + "/fit.json", s.dir + "/fit.err"),
            0)
      << SyncSlurp(s.dir + "/fit.err");
  const nlohmann::json f = nlohmann::json::parse(SyncSlurp(s.dir + "/fit.json"));
  EXPECT_TRUE(f.at("forced").get<bool>());
  EXPECT_TRUE(f.at("converged").get<bool>()) << f.dump();
  // Oracle: the parameters of the simulation (MakeTruth), within 3 of the
  // fit's standard errors (which include the table's sampling shift the
  // fit estimates; 3: a 0.27 % chance each for a Gaussian estimate). alpha had sat 1.3e-3 rad low, 10 standard errors, while
  // the merge gave the table's acceleration as point samples (or box
  // averages) 10 ms apart, whose chord cuts its peaks near the uplift
  // threshold; the merge's least-squares chord keeps them (docs/video.md,
  // "In step with the DAQ", 5).
  const model::BlockParams b = TruthParams();
  EXPECT_NEAR(f.at("alpha").get<double>(), b.alpha, 3 * f.at("alpha_stderr").get<double>());
  EXPECT_NEAR(f.at("p").get<double>(), b.p, 3 * f.at("p_stderr").get<double>());
  EXPECT_NEAR(f.at("mu").get<double>(), b.mu, 3 * f.at("mu_stderr").get<double>());
  std::printf("fit: alpha %.5f +- %.2g (%.5f), p %.4f +- %.2g (%.4f), mu %.4f +- %.2g (%.4f), residual/noise %s\n",
              f.at("alpha").get<double>(), f.at("alpha_stderr").get<double>(), b.alpha, f.at("p").get<double>(),
              f.at("p_stderr").get<double>(), b.p, f.at("mu").get<double>(), f.at("mu_stderr").get<double>(), b.mu,
              f.at("residual_to_noise").dump().c_str());
}

// The rig's sync keys: errors name the file, line and key.
TEST(VideoSync, SyncKeysAreCheckedWithTheirLine) {
  std::vector<test::RigLed> leds;
  for (const SyncLayoutLed& led : kSyncLayout) leds.push_back({led.name, led.x, led.z});
  const test::TestCamera cam = SyncCamera();
  const std::string blink =
      test::VideoOpenError("video_sync_keys", test::VideoRigText(cam, 100, leds, "sync = \"blink\"\n", kSyncMarks), "");
  EXPECT_NE(blink.find("rig.toml:13: key 'camera.video.sync' must be \"led\""), std::string::npos) << blink;
  const std::string no_channel = test::VideoOpenError(
      "video_sync_keys", test::VideoRigText(cam, 100, leds, "sync = \"led\"\nsync_led_px = [190, 110]\n", kSyncMarks),
      "");
  EXPECT_NE(no_channel.find("key 'camera.video.sync_channel' must name the DAQ file's column"), std::string::npos)
      << no_channel;
  const std::string lone = test::VideoOpenError(
      "video_sync_keys", test::VideoRigText(cam, 100, leds, "sync_channel = \"drive\"\n", kSyncMarks), "");
  EXPECT_NE(lone.find("key 'camera.video.sync' is missing"), std::string::npos) << lone;
  const std::string table_led = test::VideoOpenError(
      "video_sync_keys",
      test::VideoRigText(cam, 100, leds, "sync = \"table\"\nsync_led_px = [190, 110]\nsync_channel = \"d\"\n",
                         kSyncMarks),
      "");
  EXPECT_NE(table_led.find("key 'camera.video.sync_led_px' is for sync = \"led\""), std::string::npos) << table_led;
  const std::string table_alone = test::VideoOpenError(
      "video_sync_keys", test::VideoRigText(cam, 100, leds, "sync = \"table\"\n", kSyncMarks), "");
  EXPECT_NE(table_alone.find("key 'camera.video.sync_channel' must name the DAQ file's column of the table's"),
            std::string::npos)
      << table_alone;
}

// The merge and the clock fit on small records written here.
TEST(VideoSync, TheMergeResamplesOnTheDaqClockAndAPeriodicDriveIsRefused) {
  // A video at 10 frames/s whose channel is 2 t (video clock), a flag
  // column, a frame missing at t = 0.5; a DAQ at 100 Hz whose column is 1.
  Record video;
  video.names = {"x", "f"};
  for (int k = 0; k <= 10; ++k) {
    if (k == 5) continue;
    video.t_s.push_back(0.1 * k);
    video.rows.push_back({0.2 * k, static_cast<double>(k)});
  }
  Record daq;
  daq.names = {"d"};
  for (int i = 0; i <= 200; ++i) {
    daq.t_s.push_back(0.01 * i);
    daq.rows.push_back({static_cast<double>(i)});
  }
  ClockFit fit;
  fit.offset_s = 0.3;
  fit.drift_ppm = 1000;
  MergeCounts c;
  const Record at_daq =
      MergeOnDaqClock(daq, video, {Resample::kLinear, Resample::kFlags}, fit, 0.1, 0.0, &c);
  // Oracle: a DAQ sample at t is at video time (t - 0.3) / 1.001, where the
  // chord of a line is the line; between frames 4 and 6 (a drop) it is NaN
  // and flagged missing (2).
  ASSERT_EQ(at_daq.names, (std::vector<std::string>{"d", "x", "f"}));
  EXPECT_EQ(c.before, 30);  // t < 0.3
  EXPECT_EQ(c.after, static_cast<int64_t>(200 - std::floor(100 * fit.DaqTime(1.0))));
  EXPECT_EQ(c.rows, static_cast<int64_t>(at_daq.t_s.size()));
  int gaps = 0;
  for (std::size_t r = 0; r < at_daq.t_s.size(); ++r) {
    const double tv = fit.VideoTime(at_daq.t_s[r]);
    EXPECT_EQ(at_daq.rows[r][0], std::round(100 * at_daq.t_s[r]));
    if (tv > 0.4 && tv < 0.6) {
      EXPECT_TRUE(std::isnan(at_daq.rows[r][1])) << tv;
      EXPECT_EQ(at_daq.rows[r][2], 2.0);
      ++gaps;
    } else {
      EXPECT_NEAR(at_daq.rows[r][1], 2 * tv, 1e-12) << tv;
    }
  }
  EXPECT_EQ(c.in_gaps, gaps);
  // On a 10 Hz grid: the DAQ's columns as the least-squares chord of their
  // own. Oracle: (1) a line's chord is the line: exact at every point; (2)
  // the chord's defining property, the residual (the DAQ's chord minus the
  // grid's) orthogonal to every hat function of the grid, here integrated
  // independently by the midpoint rule (1e-5 s: error below 1e-10) for
  // q = t^2 with a non-finite sample at 0.85 s, which splits the grid's
  // chord into [0.3, 0.8] and [0.9, 1.3] solved apart; (3) inside a run, a
  // quadratic's chord on a uniform grid is q(t_k) - h^2 / 6 + Td^2 / 6 (the
  // normal equations' interior row, the DAQ's chord adding Td^2 / 6 on
  // average, exactly where both grids align), disturbed by the run's ends
  // by (2 - sqrt 3)^j h^2 at j points from an end.
  daq.names = {"d", "q"};
  for (std::size_t i = 0; i < daq.t_s.size(); ++i) {
    daq.rows[i].push_back(i == 85 ? std::numeric_limits<double>::quiet_NaN() : daq.t_s[i] * daq.t_s[i]);
  }
  const Record grid = MergeOnDaqClock(daq, video, {Resample::kLinear, Resample::kFlags}, fit, 0.1, 10.0, &c);
  ASSERT_EQ(grid.t_s.size(), 11u);  // 1.001 s from 0.3 s
  for (std::size_t k = 0; k < grid.t_s.size(); ++k) {
    EXPECT_NEAR(grid.t_s[k], 0.3 + 0.1 * k, 1e-12);
    EXPECT_NEAR(grid.rows[k][0], 100 * grid.t_s[k], 1e-9) << k;
    EXPECT_TRUE(std::isfinite(grid.rows[k][1])) << k;
  }
  auto daq_chord = [](double t) {
    const double i = std::floor(100 * t), a = 0.01 * i, b = a + 0.01;
    return a * a + (t - a) / 0.01 * (b * b - a * a);
  };
  // Points [k0, k1] of one run: its chord's residual against each of its hats.
  auto check_run = [&](std::size_t k0, std::size_t k1) {
    for (std::size_t k = k0; k <= k1; ++k) {
      double dot = 0;
      const double lo = grid.t_s[k > k0 ? k - 1 : k], hi = grid.t_s[k < k1 ? k + 1 : k];
      const int steps = static_cast<int>(std::lround((hi - lo) / 1e-5));
      for (int j = 0; j < steps; ++j) {
        const double t = lo + (j + 0.5) * 1e-5;
        const std::size_t m = std::min<std::size_t>(k1 - 1, static_cast<std::size_t>((t - grid.t_s[0]) / 0.1));
        const double w = (t - grid.t_s[m]) / 0.1;
        const double mine = grid.rows[m][1] + w * (grid.rows[m + 1][1] - grid.rows[m][1]);
        const double hat = t < grid.t_s[k] ? (t - lo) / (grid.t_s[k] - lo) : (hi - t) / (hi - grid.t_s[k]);
        dot += (daq_chord(t) - mine) * hat * 1e-5;
      }
      EXPECT_NEAR(dot, 0.0, 1e-10) << "point " << k;
    }
  };
  check_run(0, 5);   // 0.3 .. 0.8
  check_run(6, 10);  // 0.9 .. 1.3
  const double interior = 0.6 * 0.6 - 0.01 / 6 + 1e-4 / 6;  // point 3 (0.6 s), 2 points from its run's end
  EXPECT_NEAR(grid.rows[3][1], interior, std::pow(2 - std::sqrt(3.0), 2) * 0.01);

  // Edges: a drive switched every 0.1 s exactly (periodic) pairs at every
  // period: refused, naming what was asked.
  std::vector<SyncEdge> v, d;
  for (int k = 0; k < 40; ++k) {
    v.push_back({0.1 * k, k % 2 == 0});
    d.push_back({0.1 * k + 0.2, k % 2 == 0});
  }
  try {
    (void)FitClock(v, d, 0.01, 0.005, 0.001, "A and B");
    ADD_FAILURE() << "a periodic drive was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("A and B: the sync LED's edges pair at two offsets"), std::string::npos)
        << e.what();
  }
  // Irregular and exact: the clock to rounding.
  v.clear();
  d.clear();
  double t = 0;
  uint32_t lcg = 7;
  for (int k = 0; k < 40; ++k, t += 0.05 + 0.1 * ((lcg = lcg * 1664525u + 1013904223u) >> 8) / 16777216.0) {
    v.push_back({t, k % 2 == 0});
    d.push_back({0.25 + (1 + 2e-4) * t, k % 2 == 0});
  }
  const ClockFit exact = FitClock(v, d, 0.01, 0.005, 0.001, "A and B");
  EXPECT_NEAR(exact.offset_s, 0.25, 1e-12);
  EXPECT_NEAR(exact.drift_ppm, 200, 1e-6);
  EXPECT_EQ(exact.matched, 40);
  // Every DAQ edge 6 ms off, alternately early and late: an RMS of 6 ms
  // against 3 x the 1.47 ms a 10 ms frame with 5 ms exposure and a 1 ms
  // DAQ period allow (sqrt((5^2 + 1^2 + 0.3^2) / 12) ms): refused.
  for (std::size_t k = 0; k < d.size(); ++k) d[k].t_s += k % 2 == 0 ? 0.006 : -0.006;
  try {
    (void)FitClock(v, d, 0.01, 0.005, 0.001, "A and B");
    ADD_FAILURE() << "edges 6 ms off were accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("A and B: the sync edges scatter by"), std::string::npos) << e.what();
  }
}

// sync = "table" on records made here (no video): the table's displacement
// x_daq(t) sampled at 1 kHz for 10 s, the video's view of it at 100
// frames/s for 4 s, x_video(t) = 2 x_daq(0.3 + (1 + 1e-4) t) + 0.01.
TEST(VideoSync, TheTableClockIsFoundAndAPeriodicOrUnrelatedMotionRefused) {
  const auto make = [](const std::function<double(double)>& table, std::vector<double>& td, std::vector<double>& xd,
                       std::vector<double>& tv, std::vector<double>& xv) {
    td.clear(), xd.clear(), tv.clear(), xv.clear();
    for (int i = 0; i <= 10000; ++i) td.push_back(i * 1e-3), xd.push_back(table(i * 1e-3));
    for (int k = 0; k < 400; ++k) tv.push_back(k * 0.01), xv.push_back(2 * table(0.3 + (1 + 1e-4) * k * 0.01) + 0.01);
  };
  std::vector<double> td, xd, tv, xv;
  // A chirp (1 Hz rising 0.6 Hz/s) under a Hann window: no two offsets alike.
  const auto chirp = [](double t) {
    return 0.05 * std::sin(M_PI * t / 10) * std::sin(M_PI * t / 10) * std::sin(2 * M_PI * (t + 0.3 * t * t));
  };
  make(chirp, td, xd, tv, xv);
  const MotionFit fit = FitClockByMotion(tv, xv, td, xd, 1e-3, "V and D");
  // Oracle: the offset, drift and scale the records were made with. The
  // only error is the DAQ's chord between its 1 ms samples, at most
  // a'' h^2 / 8 = (2 pi 7 Hz x 1 ms)^2 / 8 = 2.4e-4 of the amplitude at the
  // chirp's top 7 Hz: a time error below 2.4e-4 / (2 pi 7 Hz) = 5.5 us;
  // over the video's 4 s that allows 2.7 ppm of drift.
  EXPECT_NEAR(fit.clock.offset_s, 0.3, 5.5e-6);
  EXPECT_NEAR(fit.clock.drift_ppm, 100, 2.7);
  EXPECT_NEAR(fit.scale, 2.0, 2 * 2.4e-4);
  EXPECT_GT(fit.correlation, 0.999);
  const auto refusal = [&](const char* what) -> std::string {
    try {
      (void)FitClockByMotion(tv, xv, td, xd, 1e-3, "V and D");
    } catch (const std::runtime_error& e) {
      return e.what();
    }
    ADD_FAILURE() << what << " was accepted";
    return "";
  };
  // A steady 2 Hz sine matches every 0.5 s as well as at 0.3 s.
  make([](double t) { return 0.05 * std::sin(2 * M_PI * 2 * t); }, td, xd, tv, xv);
  EXPECT_NE(refusal("a periodic motion").find("V and D: the table's motion matches at two offsets"),
            std::string::npos);
  // The video sees something else (noise, an LCG): correlation ~ 1/sqrt(400).
  make(chirp, td, xd, tv, xv);
  uint32_t lcg = 11;
  for (double& x : xv) x = ((lcg = lcg * 1664525u + 1013904223u) >> 8) / 16777216.0;
  EXPECT_NE(refusal("an unrelated motion").find("V and D: the table's motion in the video correlates"),
            std::string::npos);
  // A DAQ record shorter than the video, and too few frames.
  make(chirp, td, xd, tv, xv);
  td.resize(3000), xd.resize(3000);
  EXPECT_NE(refusal("a short DAQ record").find("V and D: the DAQ record (2.999"), std::string::npos);
  make(chirp, td, xd, tv, xv);
  for (std::size_t k = 19; k < xv.size(); ++k) xv[k] = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(refusal("19 frames").find("V and D: 19 frames show the table's motion (at least 20"), std::string::npos);
}

}  // namespace
}  // namespace rocklab::video::sync
