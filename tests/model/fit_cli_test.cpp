// `rocklab fit` as a user runs it: documented JSON and text outputs, the
// PARAMS.json the model node reads, LCM-log input, and every bad-input case
// (one-line message, exit code 2). Records are synthesised by the Housner
// model integrated by the tests' RK4 reference (tests/model/fit_synthetic.h),
// the oracle of the fitted values.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>
#include <nlohmann/json.hpp>

#include "model/test_record.h"
#include "rocklab/block_state_t.hpp"
#include "tests/model/fit_synthetic.h"
#include "tests/tools/run_cli.h"
#include "tests/paper_blocks.h"

namespace rocklab::test {
namespace {

using ::rocklab::test::kBlock1;  // tests/paper_blocks.h

std::string FreeCsv(const std::string& dir, double duration_s = 8.0) {
  const std::string path = dir + "/free.csv";
  model::WriteThetaCsv(path, SyntheticFree(kBlock1, 0.6 * kBlock1.alpha, 0.3, duration_s, 500, 0.02, 1));
  return path;
}

int CountLines(const std::string& s) { return static_cast<int>(std::count(s.begin(), s.end(), '\n')); }

// Oracle: the synthetic truth (a record of the RK4 reference, seed 1) and
// the JSON names of docs/commands.md (`rocklab fit`). Measured (printed): alpha -0.099 %,
// p +0.071 %, mu -3.3e-5; tolerances 3x: 0.25 %, 0.2 %, 1e-4.
TEST(CliFit, ImpactsJsonAndParamsFile) {
  const std::string dir = ScratchDir("fit_json");
  const CliResult r = RunCli({"fit", "--input", FreeCsv(dir), "--width", "0.247", "--height", "1.0",
                              "--json", "--out", dir + "/params.json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  std::printf("impacts: alpha %+.4f %%, p %+.4f %%, mu %+.6f\n", 100 * (j.at("alpha").get<double>() / kBlock1.alpha - 1),
              100 * (j.at("p").get<double>() / kBlock1.p - 1), j.at("mu").get<double>() - kBlock1.mu);
  EXPECT_NEAR(j.at("alpha").get<double>() / kBlock1.alpha, 1.0, 0.0025);
  EXPECT_NEAR(j.at("p").get<double>() / kBlock1.p, 1.0, 0.002);
  EXPECT_NEAR(j.at("mu").get<double>(), kBlock1.mu, 1e-4);
  for (const char* key : {"mu_spread", "alpha_stderr", "p_stderr", "alpha_p_correlation", "method",
                          "quarter_time", "units", "impacts", "theory", "alpha_band"}) {
    EXPECT_TRUE(j.contains(key)) << key;
  }
  EXPECT_EQ(j.at("method"), "impacts");
  EXPECT_EQ(j.at("quarter_time"), "exact");
  EXPECT_EQ(j.at("units").at("p"), "rad/s");
  ASSERT_GE(j.at("impacts").size(), 15u);
  for (const char* key : {"n", "time", "peak", "mu_n", "residual"}) {
    EXPECT_TRUE(j.at("impacts")[1].contains(key)) << key;
  }
  const auto params = nlohmann::json::parse(ReadFile(dir + "/params.json"));
  EXPECT_EQ(params.at("alpha"), j.at("alpha"));
  EXPECT_EQ(params.at("p"), j.at("p"));
  EXPECT_EQ(params.at("mu"), j.at("mu"));
}

TEST(CliFit, TextHasTheTable2RowAndThePerImpactTable) {
  const std::string dir = ScratchDir("fit_text");
  const CliResult r = RunCli({"fit", "--input", FreeCsv(dir), "--quarter-time", "slender"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* word : {"alpha (rad)", "p (rad/s)", "fitted", "std error", "alpha-p correlation",
                           "mu_n", "residual (ms)", "quarter time slender"}) {
    EXPECT_NE(r.out.find(word), std::string::npos) << word << " missing in\n" << r.out;
  }
  EXPECT_GT(CountLines(r.out), 20);
}

// Oracle: the same free record through an LCM log (RL_THETA) as through CSV.
// The times are identical (k / 500 s is a whole number of microseconds) and
// theta differs by the CSV's 12 digits (1e-13 rad), which can tip a
// sub-sample search (grid then golden section) into a neighbouring cell: the
// fitted alpha must agree to 1 % of its standard error (1.7e-3 rad), which
// is 1.7e-5 rad (measured difference 6e-6 rad).
TEST(CliFit, LcmLogInput) {
  const std::string dir = ScratchDir("fit_lcm");
  const auto rec = SyntheticFree(kBlock1, 0.6 * kBlock1.alpha, 0.3, 8.0, 500, 0.02, 1);
  {
    lcm::LogFile log(dir + "/free.lcmlog", "w");
    ASSERT_TRUE(log.good());
    for (std::size_t k = 0; k < rec.size(); ++k) {
      rocklab::block_state_t b{};
      b.utime = static_cast<int64_t>(std::llround(rec.time_s[k] * 1e6));
      b.seq = static_cast<int64_t>(k);
      b.theta = rec.theta[k];
      std::vector<uint8_t> buf(b.getEncodedSize());
      b.encode(buf.data(), 0, static_cast<int>(buf.size()));
      lcm::LogEvent ev{};
      ev.eventnum = static_cast<int64_t>(k);
      ev.timestamp = b.utime;
      ev.channel = "RL_THETA";
      ev.datalen = static_cast<int32_t>(buf.size());
      ev.data = buf.data();
      ASSERT_EQ(log.writeEvent(&ev), 0);
    }
  }
  const CliResult a = RunCli({"fit", "--input", dir + "/free.lcmlog", "--json"});
  ASSERT_EQ(a.exit_code, 0) << a.err;
  model::WriteThetaCsv(dir + "/free.csv", rec);
  const CliResult b = RunCli({"fit", "--input", dir + "/free.csv", "--json"});
  ASSERT_EQ(b.exit_code, 0) << b.err;
  const auto ja = nlohmann::json::parse(a.out);
  const auto jb = nlohmann::json::parse(b.out);
  EXPECT_NEAR(ja.at("alpha").get<double>(), jb.at("alpha").get<double>(),
              0.01 * jb.at("alpha_stderr").get<double>());
}

// `fit --method trajectory --accel` on a forced record made through the
// whole acquisition chain, not by the fit's own model: `rocklab synth`
// writes the lab rig's raw channels (LED cameras, mirror spot, their noise,
// occlusions and dropped samples) for the lab block under a Hanning sine
// (10 mm, 3.3 Hz, 2 s from 0.2 s, 3 s at the rig's 1 kHz; Housner's model,
// the fit's), `rocklab
// reconstruct` turns them into theta, and the table acceleration goes in
// through --accel as a time,accel CSV (the synth's truth: the table motion
// itself). Oracle: the parameters synth was given (alpha atan(0.125/0.5),
// p 3.780 rad/s, mu 0.91). TOLERANCE: 1 % on each, as the library's
// forced test; the reconstruction's noise over 3000 samples (5 dropped)
// moves them by far less (measured: -0.003 %, +0.004 %, -0.001 %, printed;
// 0.5 s of CPU).
TEST(CliFit, TrajectoryWithAccelOnAReconstructedForcedRecord) {
  const std::string dir = ScratchDir("fit_forced");
  const std::string rig = std::string(ROCKLAB_SOURCE_DIR) + "/data/rigs/lab_rig.toml";
  const double alpha = 0.24497866312686414, p = 3.780, mu = 0.91;
  const CliResult synth = RunCli({"synth", "--rig", rig, "--alpha", std::to_string(alpha), "--p", "3.780",
                                  "--mu", "0.91", "--model", "housner", "--excitation",
                                  "hanning:amp=0.010,freq=3.3,duration=2,start=0.2", "--duration", "3",
                                  "--rate", "1000", "--seed", "4", "--out", dir + "/raw.csv", "--truth",
                                  dir + "/truth.csv"});
  ASSERT_EQ(synth.exit_code, 0) << synth.err;
  const CliResult rec = RunCli({"reconstruct", "--rig", rig, "--input", dir + "/raw.csv", "--out",
                                dir + "/theta.csv"});
  ASSERT_EQ(rec.exit_code, 0) << rec.err;
  {
    // time,theta,theta_dot,table_displacement,table_acceleration,... -> time,accel
    std::ifstream truth(dir + "/truth.csv");
    std::ofstream accel(dir + "/accel.csv");
    std::string line;
    std::getline(truth, line);
    accel << "time,accel\n";
    while (std::getline(truth, line)) {
      std::vector<std::string> f;
      for (std::size_t a = 0, b; a <= line.size(); a = b + 1) {
        b = std::min(line.find(',', a), line.size());
        f.push_back(line.substr(a, b - a));
      }
      ASSERT_GE(f.size(), 5u) << line;
      accel << f[0] << "," << f[4] << "\n";
    }
  }
  const CliResult r = RunCli({"fit", "--input", dir + "/theta.csv", "--accel", dir + "/accel.csv", "--method",
                              "trajectory", "--rig", rig, "--json", "--quiet"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  std::printf("trajectory fit of the reconstructed forced record: alpha %+.3f %%, p %+.3f %%, mu %+.3f %%\n",
              100 * (j.at("alpha").get<double>() / alpha - 1), 100 * (j.at("p").get<double>() / p - 1),
              100 * (j.at("mu").get<double>() / mu - 1));
  EXPECT_EQ(j.at("method"), "trajectory");
  EXPECT_EQ(j.at("table_reading"), "spline");  // the default for point samples
  EXPECT_NEAR(j.at("alpha").get<double>() / alpha, 1.0, 0.01);
  EXPECT_NEAR(j.at("p").get<double>() / p, 1.0, 0.01);
  EXPECT_NEAR(j.at("mu").get<double>() / mu, 1.0, 0.01);
}

// A record with missing samples (20 in a row and 0.1 % at random,
// as the rig simulator drops them) is fitted, and the output says what the
// fit knows. Oracle: the samples removed here, the synthetic truth (the
// RK4 reference's record; measured, printed: alpha -0.104 %, mu -3.1e-5;
// tolerances 3x: 0.3 %, 9e-5) and the documented keys.
TEST(CliFit, GappedRecordIsFittedAndTheOutputSaysWhatItKnows) {
  const std::string dir = ScratchDir("fit_gaps");
  auto rec = SyntheticFree(kBlock1, 0.6 * kBlock1.alpha, 0.3, 8.0, 500, 0.02, 1);
  const long removed = DropSamples(rec, 0.001, 5, 400, 20);
  model::WriteThetaCsv(dir + "/gaps.csv", rec);
  const CliResult r = RunCli({"fit", "--input", dir + "/gaps.csv", "--width", "0.247", "--height", "1.0", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("missing_samples").get<long>(), removed);
  EXPECT_GE(j.at("gaps").get<long>(), 2);
  EXPECT_NEAR(j.at("longest_gap").get<double>(), 21 * 0.002, 1e-9);
  std::printf("gapped: alpha %+.4f %%, mu %+.6f\n", 100 * (j.at("alpha").get<double>() / kBlock1.alpha - 1),
              j.at("mu").get<double>() - kBlock1.mu);
  EXPECT_NEAR(j.at("alpha").get<double>() / kBlock1.alpha, 1.0, 0.003);
  EXPECT_NEAR(j.at("mu").get<double>(), kBlock1.mu, 9e-5);
  EXPECT_TRUE(j.at("converged").get<bool>());
  EXPECT_GT(j.at("residual_to_noise").get<double>(), 0.5);
  EXPECT_LT(j.at("residual_to_noise").get<double>(), 1.5);
  EXPECT_TRUE(j.at("mu_stderr").is_number());
  EXPECT_TRUE(j.at("noise_residual").is_number());
  EXPECT_EQ(j.at("dof").get<int>(), j.at("residuals").get<int>() - 2);
  EXPECT_FALSE(j.at("stderr_withheld").get<bool>());
  EXPECT_EQ(j.at("units").at("residual_to_noise"), "1");
  // The chi-square verdict: chi2 / dof is residual_to_noise squared, the
  // p-value passes the 1 % significance when converged, and the impacts
  // method refined its alpha-profile starts.
  EXPECT_NEAR(j.at("chi2_per_dof").get<double>(), std::pow(j.at("residual_to_noise").get<double>(), 2), 1e-9);
  EXPECT_NEAR(j.at("chi2").get<double>(), j.at("chi2_per_dof").get<double>() * j.at("dof").get<int>(), 1e-6);
  EXPECT_GE(j.at("p_value").get<double>(), j.at("significance").get<double>());
  EXPECT_EQ(j.at("significance").get<double>(), 0.01);
  EXPECT_GT(j.at("noise_dof").get<double>(), 100.0);
  EXPECT_FALSE(j.at("noise_stated").get<bool>());
  EXPECT_GE(j.at("starts").get<int>(), 1);
  // The record's true noise stated (0.02 deg = 3.4907e-4 rad): taken as
  // exact (no noise dof) and the fit converged. Half of it: reported as
  // the noise, but each crossing and peak fit then sees a scatter beyond
  // it and takes its own (LocalNoiseScale), so the verdict stands.
  const CliResult stated = RunCli({"fit", "--input", dir + "/gaps.csv", "--noise-rad", "3.4907e-4", "--json"});
  ASSERT_EQ(stated.exit_code, 0) << stated.err;
  const auto js = nlohmann::json::parse(stated.out);
  EXPECT_TRUE(js.at("noise_stated").get<bool>());
  EXPECT_TRUE(js.at("noise_dof").is_null());
  EXPECT_TRUE(js.at("converged").get<bool>());
  const CliResult half = RunCli({"fit", "--input", dir + "/gaps.csv", "--noise-rad", "1.745e-4", "--json"});
  ASSERT_EQ(half.exit_code, 0) << half.err;
  const auto jh = nlohmann::json::parse(half.out);
  EXPECT_EQ(jh.at("noise").get<double>(), 1.745e-4);
  EXPECT_TRUE(jh.at("converged").get<bool>());
  const CliResult text = RunCli({"fit", "--input", dir + "/gaps.csv"});
  ASSERT_EQ(text.exit_code, 0) << text.err;
  for (const char* word : {"residual / noise", "converged", "missing samples"}) {
    EXPECT_NE(text.out.find(word), std::string::npos) << word << " missing in\n" << text.out;
  }
}

struct BadCase {
  std::string name;
  std::vector<std::string> args;  // after "fit"; @ is the scratch dir
  std::string expected;           // in the one-line message
};

class CliFitBadInput : public ::testing::TestWithParam<BadCase> {};

TEST_P(CliFitBadInput, ExitsWith2AndNamesTheProblem) {
  const std::string dir = ScratchDir("fit_bad");
  const auto rec = SyntheticFree(kBlock1, 0.6 * kBlock1.alpha, 0.3, 8.0, 500, 0.02, 2);
  model::WriteThetaCsv(dir + "/free.csv", rec);
  model::WriteThetaCsv(dir + "/short.csv", SyntheticFree(kBlock1, 0.6 * kBlock1.alpha, 0.3, 0.9, 500, 0.02, 3));
  model::WriteThetaCsv(dir + "/held.csv", SyntheticFree(kBlock1, 0.6 * kBlock1.alpha, 5.0, 0.0, 500, 0.02, 3));
  model::WriteThetaCsv(dir + "/fell.csv", SyntheticFree(kBlock1, 1.05 * kBlock1.alpha, 0.3, 3.0, 500, 0.02, 3));
  const auto ex = model::ParseExcitation("hanning:amp=0.010,freq=3.3,duration=4,start=0.5");
  const auto forced = SyntheticForced(kBlock1, *ex, 7.0, 250, 500, 0.02, 7);
  model::WriteThetaCsv(dir + "/forced.csv", forced);
  {
    std::ofstream accel(dir + "/accel.csv");
    accel << "time,accel\n";
    accel.precision(17);
    for (std::size_t k = 0; k < forced.table_time_s.size(); ++k) {
      accel << forced.table_time_s[k] << "," << forced.table_accel_mps2[k] << "\n";
    }
  }
  auto back = rec;
  std::swap(back.time_s[300], back.time_s[301]);
  model::WriteThetaCsv(dir + "/back.csv", back);

  std::vector<std::string> args{"fit"};
  for (std::string a : GetParam().args) {
    if (!a.empty() && a[0] == '@') a = dir + a.substr(1);
    args.push_back(a);
  }
  const CliResult r = RunCli(args);
  EXPECT_EQ(r.exit_code, 2) << r.out << r.err;
  EXPECT_EQ(CountLines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find(GetParam().expected), std::string::npos) << r.err;
}

INSTANTIATE_TEST_SUITE_P(
    Cases, CliFitBadInput,
    ::testing::Values(
        BadCase{"NoInput", {"--json"}, "--input"},
        BadCase{"MissingFile", {"--input", "@/none.csv"}, "cannot open"},
        BadCase{"TooFewImpacts", {"--input", "@/short.csv"}, "usable impacts"},
        BadCase{"NeverRocks", {"--input", "@/held.csv"}, "never rocks"},
        BadCase{"Overturns", {"--input", "@/fell.csv"}, "overturns"},
        BadCase{"ImpactsOnAForcedTest", {"--input", "@/forced.csv", "--accel", "@/accel.csv"},
                "not free rocking"},
        BadCase{"NonMonotonicTime", {"--input", "@/back.csv"}, "time does not increase"},
        BadCase{"AlphaOutsideBand", {"--input", "@/free.csv", "--width", "0.4", "--height", "1"},
                "admissible band"},
        BadCase{"BadMethod", {"--input", "@/free.csv", "--method", "guess"}, "--method"},
        BadCase{"BadQuarterTime", {"--input", "@/free.csv", "--quarter-time", "x"}, "--quarter-time"},
        BadCase{"BadTableReading", {"--input", "@/free.csv", "--table", "cubic"}, "--table must be spline or chord"},
        BadCase{"NegativeBand", {"--input", "@/free.csv", "--alpha-band-m", "-1"}, "--alpha-band-m"},
        BadCase{"RigAndWidth", {"--input", "@/free.csv", "--rig", "r.toml", "--width", "1"}, "--rig"},
        BadCase{"TrajectoryForcedNoStart", {"--input", "@/free.csv", "--method", "trajectory",
                                            "--accel", "@/none.csv"}, "cannot open"}),
    [](const ::testing::TestParamInfo<BadCase>& param_info) { return param_info.param.name; });

}  // namespace
}  // namespace rocklab::test
