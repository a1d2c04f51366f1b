// Independent oracles for the DAQ: raw frames computed
// here from the rig geometry and DESIGN.md's measurement models, never by
// daq/rig_simulator.cpp, fed through the reconstruction, the processor and
// `rocklab reconstruct`. A sign or geometry convention shared by the
// simulator and the reconstruction cannot pass here unseen.
//
// The measurement models, as DESIGN.md and docs/acquisition.md
// state them, and the frames built from them:
// - Frames: block frame origin at the centre of the base, x along the
//   rocking direction, z up; rig frame = block frame at rest with the table
//   at zero. theta > 0 tips the block towards +x about its +x base corner
//   P = (+xp, 0), xp = b - chamfer (theta < 0: about (-xp, 0)).
//   Turning the block by theta about P towards +x is a clockwise turn in the
//   (x, z) plane (x right, z up), so a block point (x, z) goes to
//     X = P + (x - P) cos(theta) + z sin(theta)
//     Z =   - (x - P) sin(theta) + z cos(theta)
//   (the top, (0, 2h), moves to +x: X ~ 2h theta > 0). The whole block then
//   moves with the table (u), slides on it (slide) and lifts (lift):
//   X += u + slide, Z += lift. A lateral LED is seen at (X, Z) in the rig frame.
// - LED-mirror: theta = 0.5 atan((s - s0) / D), so s = s0 + D tan(2 theta);
//   the orthogonal spot n = n0 + D tan(2 tilt).
// - Out-of-plane pair: LED a at x = -spacing/2 and b at +spacing/2 on the
//   block; a twist about the vertical (right-handed: x turns towards y) and an
//   out-of-plane shift y0 put them at y_a = y0 - (spacing/2) sin(twist),
//   y_b = y0 + (spacing/2) sin(twist) (docs/acquisition.md: twist = asin((y_b - y_a) /
//   spacing), out_of_plane = (y_a + y_b) / 2).
// - Table: displacement u and acceleration u'' as their sensors read them.
// - Calibration: physical = gain * raw + offset, so raw = (physical - offset) / gain
//   with each channel's gain and offset from the rig file.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "daq/processor.h"
#include "daq/reconstruction.h"
#include "daq/rig_config.h"
#include "rocklab/event2_t.hpp"
#include "tests/tools/run_cli.h"
#include "common/units.h"

namespace rocklab::daq {
namespace {

using ::rocklab::common::kPi;  // one pi for the tests a unity batch shares

const std::string kRigPath = std::string(ROCKLAB_SOURCE_DIR) + "/data/rigs/block1_rig.toml";

// The true motion at one sample.
struct Truth {
  double theta{};   // rad
  double slide{};   // block on the table, m
  double lift{};    // block off the table, m
  double twist{};   // about the vertical, rad
  double y0{};      // out-of-plane shift, m
  double tilt{};    // out-of-plane tilt seen by the mirror, rad
  double u{};       // table displacement, m
  double accel{};   // table acceleration, m/s^2
};

// A lateral LED's position in the rig frame (the model at the top).
void LedWorld(const RigConfig& rig, double x, double z, const Truth& m, double& X, double& Z) {
  const double p = (m.theta >= 0 ? 1.0 : -1.0) * (0.5 * rig.block.width_m - rig.block.chamfer_m);
  const double c = std::cos(m.theta), s = std::sin(m.theta);
  X = p + (x - p) * c + z * s + m.u + m.slide;
  Z = -(x - p) * s + z * c + m.lift;
}

// The physical value each sensor role reads for `m` (the models at the top).
std::map<std::string, double> Physical(const RigConfig& rig, const Truth& m) {
  std::map<std::string, double> v;
  v["mirror.s"] = rig.mirror.rest_s_m + rig.mirror.lever_m * std::tan(2 * m.theta);
  v["mirror.n"] = rig.mirror.rest_n_m + rig.mirror.lever_m * std::tan(2 * m.tilt);
  for (const auto& cam : rig.cameras) {
    for (const auto& led : cam.leds) {
      double X = 0, Z = 0;
      LedWorld(rig, led.x_m, led.z_m, m, X, Z);
      v[cam.name + "." + led.name + ".x"] = X;
      v[cam.name + "." + led.name + ".z"] = Z;
    }
  }
  const double half = 0.5 * rig.out_of_plane.spacing_m;
  v["oop.a"] = m.y0 - half * std::sin(m.twist);
  v["oop.b"] = m.y0 + half * std::sin(m.twist);
  v["table.displacement"] = m.u;
  v["table.acceleration"] = m.accel;
  return v;
}

// Raw values in the rig's channel order.
std::vector<double> RawFrame(const RigConfig& rig, const Truth& m) {
  const auto phys = Physical(rig, m);
  std::vector<double> raw;
  for (const auto& ch : rig.channels) raw.push_back((phys.at(ch.sensor) - ch.offset) / ch.gain);
  return raw;
}

std::vector<std::string> Names(const RigConfig& rig) {
  std::vector<std::string> names;
  for (const auto& ch : rig.channels) names.push_back(ch.name);
  return names;
}

// Oracle: the geometry at the top, for a grid of motions (both corners, the
// table moved, sliding, lifting, twisting). Tolerances: 1e-9 rad and 1e-9 m;
// the frames are exact doubles, so only round-off of the fit (~1e-15) and of
// the calibration (~1e-13 m for pixel gains of 5e-4 m) separates them.
TEST(IndependentOracleTest, ReconstructionRecoversTheGeometrysMotion) {
  const RigConfig rig = LoadRigConfig(kRigPath);
  ASSERT_TRUE(rig.mirror.present);
  ASSERT_EQ(rig.cameras.size(), 2u);
  const std::string path = "oracle";
  Reconstructor rec(rig, Names(rig), path);
  // The oracle's own convention, checked on its frames: theta > 0 moves the
  // top LEDs towards +x and lifts the -x side of the base.
  {
    Truth m;
    m.theta = 0.05;
    double X = 0, Z = 0, X0 = 0, Z0 = 0;
    LedWorld(rig, -0.1, 0.85, m, X, Z);
    LedWorld(rig, -0.1, 0.85, Truth{}, X0, Z0);
    ASSERT_GT(X, X0);
    LedWorld(rig, -0.1235, 0.0, m, X, Z);
    ASSERT_GT(Z, 0.0);
  }
  int frames = 0;
  for (double theta : {-0.1, -0.02, -1e-4, 0.0, 1e-4, 0.02, 0.1}) {
    for (double slide : {0.0, 0.003}) {
      for (double lift : {0.0, 0.002}) {
        for (double twist : {0.0, -0.03}) {
          Truth m;
          m.theta = theta;
          m.slide = slide;
          m.lift = lift;
          m.twist = twist;
          m.y0 = 0.0005;
          m.tilt = 0.002;
          m.u = 0.006 * std::sin(7.0 * frames);  // the table somewhere in +-6 mm
          m.accel = -3.0;
          Frame f;
          f.seq = frames;
          f.time_s = frames * 1e-3;
          f.values = RawFrame(rig, m);
          BlockState s;
          rec.Reconstruct(f, s);
          ++frames;
          SCOPED_TRACE("theta " + std::to_string(theta) + " slide " + std::to_string(slide) + " lift " +
                       std::to_string(lift) + " twist " + std::to_string(twist));
          EXPECT_NEAR(s.theta_mirror, theta, 1e-9);
          EXPECT_NEAR(s.theta_camera, theta, 1e-9);
          EXPECT_NEAR(s.theta, theta, 1e-9);
          EXPECT_NEAR(s.sliding, slide, 1e-9);
          EXPECT_NEAR(s.jump, lift, 1e-9);
          EXPECT_NEAR(s.twist, twist, 1e-9);
          EXPECT_NEAR(s.out_of_plane, 0.0005, 1e-9);
          EXPECT_NEAR(s.tilt, 0.002, 1e-9);
          EXPECT_NEAR(s.table_displacement, m.u, 1e-9);
          EXPECT_NEAR(s.table_acceleration, -3.0, 1e-9);
          EXPECT_EQ(s.leds_used, 4);
          // Tolerances of block1_rig.toml: sliding 1 mm, jump 1 mm, twist 0.01 rad.
          EXPECT_EQ((s.flags & kFlagSliding) != 0, slide > 0.001);
          EXPECT_EQ((s.flags & kFlagJump) != 0, lift > 0.001);
          EXPECT_EQ((s.flags & kFlagTwist) != 0, std::abs(twist) > 0.01);
          EXPECT_EQ(s.flags & (kFlagDisagree | kFlagOutOfPlane | kFlagNoMirror | kFlagNoCamera), 0);
        }
      }
    }
  }
}

// Oracle: each camera alone (two LEDs) must also give theta and, where the
// pivot is precise enough, the same sliding: the high camera's LEDs hidden
// (NaN) leave the low pair; the low camera's hidden leave the high pair.
TEST(IndependentOracleTest, EitherCameraAloneRecoversTheta) {
  const RigConfig rig = LoadRigConfig(kRigPath);
  Reconstructor rec(rig, Names(rig), "oracle");
  for (const std::string hidden : {"high", "low"}) {
    for (double theta : {-0.05, 0.03}) {
      Truth m;
      m.theta = theta;
      m.u = -0.004;
      Frame f;
      f.values = RawFrame(rig, m);
      for (std::size_t i = 0; i < rig.channels.size(); ++i) {
        if (rig.channels[i].sensor.rfind(hidden + ".", 0) == 0) f.values[i] = std::nan("");
      }
      BlockState s;
      rec.Reconstruct(f, s);
      EXPECT_EQ(s.leds_used, 2) << hidden;
      EXPECT_NEAR(s.theta_camera, theta, 1e-9) << hidden;
    }
  }
}

class Collect final : public ProcessorSink {
 public:
  void OnBlockState(const BlockState& s) override { blocks.push_back(s); }
  void OnTableState(const TableState& s) override { tables.push_back(s); }
  void OnEvent(const DaqEvent& e) override { events.push_back(e); }
  std::vector<BlockState> blocks;
  std::vector<TableState> tables;
  std::vector<DaqEvent> events;
};

// The time series of the processor and file tests: theta = A sin(w t) (both
// corners, 1.5 Hz, 0.03 rad), the table at 2 Hz, 6 mm, a 3 mm slip at 1.2 s
// and a 0.03 rad twist from 1.5 s; 2 s at the rig's 1 kHz.
constexpr double kA = 0.03, kW = 2 * kPi * 1.5, kU = 0.006, kWt = 2 * kPi * 2.0;
Truth SeriesAt(double t) {
  Truth m;
  m.theta = kA * std::sin(kW * t);
  m.u = kU * std::sin(kWt * t);
  m.accel = -kU * kWt * kWt * std::sin(kWt * t);
  m.slide = t >= 1.2 - 1e-9 ? 0.003 : 0.0;
  m.twist = t >= 1.5 - 1e-9 ? 0.03 : 0.0;
  return m;
}

// theta_dot of the Savitzky-Golay differentiator of order 2 over 2m+1
// samples (docs/acquisition.md), for theta = A sin(w t), at an interior sample t0. The
// least-squares quadratic c0 + c1 k + c2 k^2 on k = -m..m has c1 = sum k y_k /
// sum k^2 (k is orthogonal to 1 and k^2 on a symmetric window), and
// sum k A sin(w (t0 + k h)) = A cos(w t0) sum k sin(w k h) (the cos(w k h)
// part is even), so theta_dot = A w cos(w t0) F with
// F = sum k sin(w k h) / (w h sum k^2) (F -> 1 as h -> 0).
double SgThetaDot(double t0, int m, double h) {
  double num = 0, den = 0;
  for (int k = -m; k <= m; ++k) {
    num += k * std::sin(kW * k * h);
    den += static_cast<double>(k) * k;
  }
  return kA * kW * std::cos(kW * t0) * num / (kW * h * den);
}

// Oracle: the processor on the series: theta, theta_dot (the closed form
// above, at interior samples), sliding, twist, the table acceleration of the
// same sample (docs/acquisition.md: RL_TABLE fields belong to one sample), and the
// SLIDING and TWIST events at the times the slip and the twist happen.
// Tolerances: 1e-9 rad, rad/s, m, m/s^2 (round-off only; the SG weights are
// solved numerically, ~1e-12 relative).
TEST(IndependentOracleTest, ProcessorRecoversAKnownMotion) {
  const RigConfig rig = LoadRigConfig(kRigPath);
  Collect sink;
  Processor proc(rig, Names(rig), "oracle", sink);
  const double h = 1.0 / rig.sample_rate_hz;
  const int n = 2000;
  for (int k = 0; k < n; ++k) {
    Frame f;
    f.seq = k;
    f.time_s = k * h;
    f.values = RawFrame(rig, SeriesAt(f.time_s));
    proc.Process(f);
  }
  proc.Finish();
  ASSERT_EQ(sink.blocks.size(), static_cast<std::size_t>(n));
  ASSERT_EQ(sink.tables.size(), static_cast<std::size_t>(n));
  const int m = rig.HalfWindow(rig.theta_dot);
  ASSERT_EQ(m, 5);
  double worst_dot = 0;
  for (const BlockState& s : sink.blocks) {
    const Truth t = SeriesAt(s.time_s);
    ASSERT_NEAR(s.time_s, s.seq * h, 1e-12);
    ASSERT_NEAR(s.theta, t.theta, 1e-9) << s.time_s;
    ASSERT_NEAR(s.sliding, t.slide, 1e-9) << s.time_s;
    ASSERT_NEAR(s.twist, t.twist, 1e-9) << s.time_s;
    EXPECT_EQ((s.flags & kFlagSliding) != 0, t.slide > 0.001) << s.time_s;
    EXPECT_EQ((s.flags & kFlagTwist) != 0, t.twist > 0.01) << s.time_s;
    if (s.seq >= m && s.seq < n - m) {
      ASSERT_NEAR(s.theta_dot, SgThetaDot(s.time_s, m, h), 1e-9) << s.time_s;
      worst_dot = std::max(worst_dot, std::abs(s.theta_dot - kA * kW * std::cos(kW * s.time_s)));
    }
  }
  // The smoothing's own bias on this motion (1 - F ~ (w m h)^2 / 10 relative).
  std::printf("theta_dot: max |SG - exact derivative| = %.3e rad/s\n", worst_dot);
  for (const TableState& s : sink.tables) {
    ASSERT_NEAR(s.acceleration, SeriesAt(s.time_s).accel, 1e-9) << s.time_s;
    ASSERT_NEAR(s.displacement, SeriesAt(s.time_s).u, 1e-9) << s.time_s;
  }
  auto first = [&](int8_t kind) -> const DaqEvent* {
    for (const auto& e : sink.events) {
      if (e.kind == kind) return &e;
    }
    return nullptr;
  };
  const DaqEvent* slid = first(rocklab::event2_t::SLIDING);
  const DaqEvent* twisted = first(rocklab::event2_t::TWIST);
  ASSERT_NE(slid, nullptr);
  ASSERT_NE(twisted, nullptr);
  EXPECT_EQ(slid->utime, 1200000);
  EXPECT_NEAR(slid->value, 0.003, 1e-9);
  EXPECT_EQ(twisted->utime, 1500000);
  EXPECT_NEAR(twisted->value, 0.03, 1e-9);
}

// Oracle: a recorded file written here, as a DAQ would export it: its own
// column order (the rig's reversed), an extra column the rig does not name,
// values at 10 significant digits like an instrument's export. Through
// `rocklab reconstruct`, theta, sliding and twist come back within what 10
// digits carry: tolerances 1e-8 rad for theta (the mirror's raw volts, ~1
// V, at 1e-10 relative, through a lever of 2 m: ~1e-11 rad; the cameras'
// pixels, ~1000, at 1e-7 pixel: 5e-11 m, over 0.7 m LED spans: ~1e-10 rad),
// 1e-8 m for sliding and 1e-8 rad for twist.
TEST(IndependentOracleTest, ReconstructCommandRecoversAFileWrittenOutsideRocklab) {
  const RigConfig rig = LoadRigConfig(kRigPath);
  const std::string dir = ::rocklab::test::ScratchDir("independent_oracle");
  const std::string raw = dir + "/raw.csv", out = dir + "/theta.csv";
  {
    std::ofstream f(raw);
    f << "time";
    for (auto it = rig.channels.rbegin(); it != rig.channels.rend(); ++it) f << "," << it->name;
    f << ",room_temp_C\n";
    char buf[64];
    for (int k = 0; k < 2000; ++k) {
      const double t = k * 1e-3;
      std::snprintf(buf, sizeof buf, "%.3f", t);
      f << buf;
      const auto values = RawFrame(rig, SeriesAt(t));
      for (auto it = values.rbegin(); it != values.rend(); ++it) {
        std::snprintf(buf, sizeof buf, ",%.10g", *it);
        f << buf;
      }
      f << ",21.5\n";
    }
  }
  const ::rocklab::test::CliResult r =
      ::rocklab::test::RunCli({"reconstruct", "--rig", kRigPath, "--input", raw, "--out", out});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::ifstream in(out);
  std::string line;
  std::getline(in, line);
  ASSERT_EQ(line, "time,theta,theta_dot,theta_mirror,theta_camera,sliding,twist,out_of_plane,flags");
  int rows = 0;
  double worst_theta = 0, worst_cam = 0, worst_slide = 0, worst_twist = 0;
  while (std::getline(in, line)) {
    double t, theta, theta_dot, th_m, th_c, sliding, twist, oop;
    int flags;
    ASSERT_EQ(std::sscanf(line.c_str(), "%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf,%d", &t, &theta, &theta_dot, &th_m, &th_c,
                          &sliding, &twist, &oop, &flags),
              9)
        << line;
    const Truth m = SeriesAt(t);
    worst_theta = std::max(worst_theta, std::abs(theta - m.theta));
    worst_cam = std::max(worst_cam, std::abs(th_c - m.theta));
    worst_slide = std::max(worst_slide, std::abs(sliding - m.slide));
    worst_twist = std::max(worst_twist, std::abs(twist - m.twist));
    EXPECT_EQ((flags & kFlagSliding) != 0, m.slide > 0.001) << line;
    EXPECT_EQ((flags & kFlagTwist) != 0, m.twist > 0.01) << line;
    ++rows;
  }
  std::printf("reconstruct: %d rows, max error theta %.2e rad, camera %.2e rad, sliding %.2e m, twist %.2e rad\n",
              rows, worst_theta, worst_cam, worst_slide, worst_twist);
  EXPECT_EQ(rows, 2000);
  EXPECT_LT(worst_theta, 1e-8);
  EXPECT_LT(worst_cam, 1e-8);
  EXPECT_LT(worst_slide, 1e-8);
  EXPECT_LT(worst_twist, 1e-8);
}

}  // namespace
}  // namespace rocklab::daq
