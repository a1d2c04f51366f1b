// `rocklab synth` -> `rocklab reconstruct`, and `rocklab daq`, through the binary. Oracles: the
// truth file synth writes (the model's theta and the injected faults) and the
// noise synth injects (the lab rig's typical figures times --noise-scale).
#include <signal.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>

#include "daq/reconstruction.h"
#include "daq/rig_config.h"
#include "daq/rig_simulator.h"
#include "rocklab/health2_t.hpp"
#include "tests/daq/daq_test_util.h"
#include "tests/tools/log_count.h"
#include "tests/tools/run_cli.h"
#include "tests/tools/udpm_netns.h"
#include "tests/skip.h"

namespace rocklab::daq {
namespace {

using test::Csv;
using test::ReadCsv;

// Runs the CLI; returns its exit code, stderr in `err`.
int Rocklab(const std::string& args, std::string* err = nullptr) {
  const std::string err_path = test::ScratchDir() + "/stderr.txt";
  const int status = std::system((std::string(ROCKLAB_BINARY) + " " + args + " 2>" + err_path).c_str());
  if (err != nullptr) {
    std::ifstream in(err_path);
    std::stringstream text;
    text << in.rdbuf();
    *err = text.str();
  }
  return WEXITSTATUS(status);
}

// Free rocking of the lab rig's block (alpha, p, mu of its 0.25 x 1.0 m
// rectangle, docs/errata.md item 1) from 0.1 rad, at the rig's 1 kHz.
const char* kScenario = "--alpha 0.24497866312686414 --p 3.780 --mu 0.91 --theta0 0.1 --duration 3 --rate 1000";

std::string Synth(const std::string& name, const std::string& extra) {
  const std::string dir = test::ScratchDir();
  const std::string cmd = "synth --rig " + test::LabRigPath() + " " + kScenario + " " + extra +
                          " --out " + dir + "/" + name + " --truth " + dir + "/" + name + ".truth.csv";
  std::string err;
  EXPECT_EQ(Rocklab(cmd, &err), 0) << err;
  return dir + "/" + name;
}

Csv Reconstruct(const std::string& raw) {
  std::string err;
  EXPECT_EQ(Rocklab("reconstruct --rig " + test::LabRigPath() + " --input " + raw + " --out " + raw +
                        ".theta.csv",
                    &err),
            0)
      << err;
  return ReadCsv(raw + ".theta.csv");
}

// Truth rows by sample number.
std::map<long, std::vector<double>> TruthBySample(const std::string& raw) {
  const Csv truth = ReadCsv(raw + ".truth.csv");
  std::map<long, std::vector<double>> by;
  for (const auto& r : truth.rows) by[std::lround(r[0] * 1000)] = r;
  return by;
}

TEST(SynthReconstruct, HeaderIsExactlyTheDocumentedOne) {
  const std::string raw = Synth("hdr.csv", "--seed 1");
  Reconstruct(raw);
  std::ifstream out(raw + ".theta.csv");
  std::string header;
  std::getline(out, header);
  EXPECT_EQ(header, "time,theta,theta_dot,theta_mirror,theta_camera,sliding,twist,out_of_plane,flags");
}

// --hold: the block held at theta0 (theta_dot 0) for the hold's whole
// samples, then the scenario shifted by the hold. Oracle: the truth of the
// same scenario without a hold (same model, same rate), sample by sample.
TEST(SynthReconstruct, HoldShiftsTheRunAfterAHeldStart) {
  const Csv plain = ReadCsv(Synth("nohold.csv", "--seed 1") + ".truth.csv");
  const Csv held = ReadCsv(Synth("hold.csv", "--seed 1 --hold 0.25") + ".truth.csv");
  const size_t t = held.Col("time"), th = held.Col("theta"), thd = held.Col("theta_dot");
  ASSERT_EQ(held.rows.size(), plain.rows.size() + 250);
  for (size_t k = 0; k < 250; ++k) {
    ASSERT_NEAR(held.rows[k][t], k * 0.001, 1e-9);
    ASSERT_EQ(held.rows[k][th], 0.1);
    ASSERT_EQ(held.rows[k][thd], 0.0);
  }
  for (size_t k = 0; k < plain.rows.size(); ++k) {
    ASSERT_NEAR(held.rows[k + 250][t], plain.rows[k][t] + 0.25, 1e-9);
    ASSERT_EQ(held.rows[k + 250][th], plain.rows[k][th]) << k;  // the same run, only later
  }
  std::string err;
  EXPECT_EQ(Rocklab("synth --rig " + test::LabRigPath() + " " + kScenario + " --hold -1 --out x.csv --truth y.csv",
                    &err),
            2);
  EXPECT_NE(err.find("--hold"), std::string::npos) << err;
}

TEST(SynthReconstruct, RoundTripRecoversThetaWithinTheInjectedNoise) {
  const double scale = 2.0;
  const std::string raw = Synth("rt.csv", "--seed 5 --noise-scale 2");
  const Csv theta = Reconstruct(raw);
  const auto truth = TruthBySample(raw);
  const RigConfig rig = LoadRigConfig(test::LabRigPath());
  const SimulatorNoise noise = SimulatorNoise::Typical().Scaled(scale);
  // Best theta is the mirror's: sigma = sigma_s cos^2(2 theta) / (2 D), within
  // 4 % of sigma_s / (2 D) for |theta| <= 0.1.
  const double sigma_m = noise.mirror_m / (2 * rig.mirror.lever_m);
  // Cameras with all LEDs: sigma_led / sqrt(sum |p - centroid|^2).
  double cx = 0, cz = 0, count = 0, spread = 0;
  for (const auto& cam : rig.cameras) {
    for (const auto& led : cam.leds) cx += led.x_m, cz += led.z_m, ++count;
  }
  for (const auto& cam : rig.cameras) {
    for (const auto& led : cam.leds) spread += std::pow(led.x_m - cx / count, 2) + std::pow(led.z_m - cz / count, 2);
  }
  const double sigma_c = noise.led_m / std::sqrt(spread);
  double ss = 0, ss_d = 0, max_err = 0;
  const size_t c_theta = theta.Col("theta"), c_m = theta.Col("theta_mirror"),
               c_c = theta.Col("theta_camera"), c_f = theta.Col("flags");
  for (const auto& r : theta.rows) {
    const auto& t = truth.at(std::lround(r[0] * 1000));
    ASSERT_EQ(t[7], 0.0) << "a dropped sample was reconstructed at " << r[0];
    ss += std::pow(r[c_theta] - t[1], 2);
    ss_d += std::pow(r[c_m] - r[c_c], 2);
    max_err = std::max(max_err, std::abs(r[c_theta] - t[1]));
    EXPECT_EQ(static_cast<int>(r[c_f]) & kFlagDisagree, 0) << r[0];
  }
  const double n = static_cast<double>(theta.rows.size());
  ASSERT_GT(n, 2900);
  std::printf("theta RMS error %.3g rad = %.3f sigma_m; mirror-camera RMS %.3g rad = %.3f of the "
              "combined sigma; max error %.2f sigma_m\n",
              std::sqrt(ss / n), std::sqrt(ss / n) / sigma_m, std::sqrt(ss_d / n),
              std::sqrt(ss_d / n) / std::hypot(sigma_m, sigma_c), max_err / sigma_m);
  // ~3000 samples: the sample RMS is within 1/sqrt(2n) = 1.3 % (1 sigma);
  // with the 4 % of the cos^2 factor, [0.92, 1.05] is 4 sigma wide.
  EXPECT_GT(std::sqrt(ss / n) / sigma_m, 0.92);
  EXPECT_LT(std::sqrt(ss / n) / sigma_m, 1.05);
  EXPECT_LT(max_err, 6 * sigma_m);
  // Mirror and cameras agree: their difference is the combined noise. 1 %
  // of the LEDs are hidden, so ~4 % of the fits use three LEDs (sigma up to
  // 1.5x): the RMS may exceed the 4-LED figure by a few %; 10 % allowed.
  EXPECT_LT(std::sqrt(ss_d / n) / std::hypot(sigma_m, sigma_c), 1.10);
  EXPECT_GT(std::sqrt(ss_d / n) / std::hypot(sigma_m, sigma_c), 0.95);
}

// A fault at t_fault: first flagged sample within 10 ms after it, none
// before; the same run without the fault has no check flag at all.
void ExpectFaultFlagged(const std::string& option, double t_fault, int flag) {
  const std::string raw = Synth("fault.csv", "--seed 9 " + option);
  const Csv theta = Reconstruct(raw);
  const size_t c_f = theta.Col("flags");
  double first = -1;
  for (const auto& r : theta.rows) {
    if ((static_cast<int>(r[c_f]) & flag) && first < 0) first = r[0];
  }
  ASSERT_GE(first, t_fault) << option;
  EXPECT_LE(first - t_fault, 0.010) << option;

  const Csv clean = Reconstruct(Synth("clean.csv", "--seed 9"));
  const int checks = kFlagSliding | kFlagJump | kFlagTwist | kFlagOutOfPlane | kFlagDisagree;
  for (const auto& r : clean.rows) ASSERT_EQ(static_cast<int>(r[c_f]) & checks, 0) << r[0];
}

TEST(SynthReconstruct, SlipOf3mmFlaggedWithin10ms) {
  ExpectFaultFlagged("--slip 0.003@1.2345", 1.2345, kFlagSliding);
}

TEST(SynthReconstruct, TwistFlaggedWithin10ms) {
  ExpectFaultFlagged("--twist 0.03@2.0005", 2.0005, kFlagTwist);
}

TEST(SynthReconstruct, LvmWithDecimalCommaGivesTheSameResultAsCsv) {
  // Oracle: the same seed writes the same digits in both formats, so the
  // reconstruction must be identical, byte for byte.
  const Csv csv = Reconstruct(Synth("same.csv", "--seed 4"));
  const std::string lvm = Synth("same.lvm", "--seed 4 --decimal-comma");
  std::ifstream head(lvm);
  std::string line;
  for (int i = 0; i < 5; ++i) std::getline(head, line);
  EXPECT_EQ(line, "Decimal_Separator\t,");
  std::string a, b;
  {
    std::ifstream x(test::ScratchDir() + "/same.csv.theta.csv");
    std::stringstream s;
    s << x.rdbuf();
    a = s.str();
  }
  Reconstruct(lvm);
  {
    std::ifstream x(lvm + ".theta.csv");
    std::stringstream s;
    s << x.rdbuf();
    b = s.str();
  }
  EXPECT_FALSE(a.empty());
  EXPECT_EQ(a, b);
}

TEST(SynthReconstruct, BadOptionsAndInputsExitWithUsageErrors) {
  std::string err;
  EXPECT_EQ(Rocklab("synth --rig " + test::LabRigPath() + " " + kScenario +
                        " --slip 3mm --out " + test::ScratchDir() + "/x.csv --truth " + test::ScratchDir() + "/y.csv",
                    &err),
            2);
  EXPECT_EQ(err, "rocklab: --slip must be SIZE@TIME_S (e.g. 0.003@2.5), got '3mm'\n");
  EXPECT_EQ(Rocklab("synth --rig " + test::LabRigPath() +
                        " --alpha 0.2 --p 3 --mu 0.9 --duration 1 --rate 500 --out " + test::ScratchDir() + "/x.csv "
                        "--truth " + test::ScratchDir() + "/y.csv",
                    &err),
            2);
  EXPECT_EQ(err.rfind("rocklab: --rate must be the rig's sample_rate_hz", 0), 0u) << err;
  EXPECT_EQ(Rocklab("reconstruct --rig " + test::LabRigPath() + " --input /nonexistent.csv --out " + test::ScratchDir() + "/z.csv", &err), 2);
  EXPECT_EQ(err, "rocklab: --input: /nonexistent.csv: cannot open the input file\n");
  const std::string wrong = test::WriteFile("wrong.csv", "time,mirror_s\n0,1\n");
  EXPECT_EQ(Rocklab("reconstruct --rig " + test::LabRigPath() + " --input " + wrong + " --out " + test::ScratchDir() + "/z.csv", &err), 2);
  EXPECT_NE(err.find("channel 'mirror_n' (sensor 'mirror.n') is not in " + wrong), std::string::npos) << err;
  EXPECT_EQ(Rocklab("reconstruct --rig /nonexistent.toml --input " + wrong + " --out " + test::ScratchDir() + "/z.csv", &err), 2);
  EXPECT_EQ(err, "rocklab: --rig: /nonexistent.toml: cannot open the rig file\n");
}

// A file none of whose rows can be used, and a
// read error, end the command with a non-zero exit and a message naming the
// file (they were exit 0 with nothing, or half the rows, written).
TEST(SynthReconstruct, UnusableInputsExitNonZeroNamingTheFile) {
  const RigConfig rig = LoadRigConfig(test::LabRigPath());
  std::string header = "time";
  std::string row = "x";
  for (const ChannelConfig& c : rig.channels) {
    header += "," + c.name;
    row += ",1";
  }
  const std::string bad = test::WriteFile("allbad.csv", header + "\n" + row + "\n" + row + "\n");
  std::string err;
  EXPECT_EQ(Rocklab("reconstruct --rig " + test::LabRigPath() + " --input " + bad + " --out " + test::ScratchDir() + "/z.csv", &err), 1);
  EXPECT_NE(err.find("rocklab: " + bad + ": none of the 2 data rows could be used"), std::string::npos) << err;
  const std::string dir = test::ScratchDir() + "/folder.csv";
  ASSERT_EQ(std::system(("mkdir -p " + dir).c_str()), 0);
  EXPECT_EQ(Rocklab("reconstruct --rig " + test::LabRigPath() + " --input " + dir + " --out " + test::ScratchDir() + "/z.csv", &err), 2);
  EXPECT_NE(err.find(dir + ": read error after line 0"), std::string::npos) << err;
  // The same input through the DaqNode (`run`, `daq`): the read ends with
  // kError, the nodes shut down in order, the command exits 1 naming the file.
  EXPECT_EQ(Rocklab("run --rig " + test::LabRigPath() + " --input " + bad + " --max", &err), 1);
  EXPECT_NE(err.find("run: " + bad + ": none of the 2 data rows could be used"), std::string::npos) << err;
  EXPECT_EQ(Rocklab("daq --rig " + test::LabRigPath() + " --input " + bad + " --max --lcm-url memq://", &err), 1);
  EXPECT_NE(err.find(bad + ": none of the 2 data rows could be used"), std::string::npos) << err;
}

}  // namespace
}  // namespace rocklab::daq

namespace rocklab::daq {
namespace {

// `rocklab daq` in a private network namespace (udpm, ttl=0) recorded by
// rocklab record, stopped by SIGINT half way: exit 0, every frame read was
// published (RL_RAW count = the frames the final health reports), and the
// last RL_HEALTH says "stopped". Skips when no namespace can be made.
TEST(DaqCommand, SigintStopsPublishesWhatWasReadAndExitsZero) {
  const std::string raw = Synth("daq.csv", "--seed 2");  // 3 s of data
  const std::string why = rocklab::test::EnterPrivateNetwork();
  if (!why.empty()) ROCKLAB_SKIP(why);
  const std::string log = test::ScratchDir() + "/daq.lcmlog";
  const pid_t logger = rocklab::test::StartRecorder(log, "RL_RAW|RL_HEALTH");
  ASSERT_GT(logger, 0) << "rocklab record did not start";
  const pid_t daq = rocklab::test::StartCli(
      {"daq", "--rig", test::LabRigPath(), "--input", raw, "--speed", "1", "--lcm-url",
       rocklab::test::kUdpmUrl},
      test::ScratchDir() + "/daq.out", test::ScratchDir() + "/daq.err");
  // SIGINT once 300 frames are in the log (0.3 s of the 3 s file on the
  // sample clock; the recorder flushes within 100 ms), not after a fixed
  // sleep; 2.6 s of margin before the file would end by itself.
  EXPECT_TRUE(rocklab::test::WaitUntil([&] { return rocklab::test::CountLogEvents(log, "RL_RAW") >= 300; }))
      << "rocklab daq did not publish 300 frames within 60 s";
  EXPECT_EQ(rocklab::test::StopProcess(daq, SIGINT), 0);
  EXPECT_EQ(rocklab::test::StopRecorder(logger, log), 0);

  lcm::LogFile in(log, "r");
  ASSERT_TRUE(in.good());
  int64_t raw_frames = 0;
  rocklab::health2_t last;
  while (const lcm::LogEvent* ev = in.readNextEvent()) {
    if (ev->channel == "RL_RAW") ++raw_frames;
    if (ev->channel == "RL_HEALTH") last.decode(ev->data, 0, ev->datalen);
  }
  EXPECT_EQ(last.state, "stopped");
  EXPECT_GT(raw_frames, 0);
  EXPECT_LT(raw_frames, 2900);  // stopped before the end of the 3 s file
  EXPECT_EQ(last.count_in, raw_frames);
}

}  // namespace
}  // namespace rocklab::daq
