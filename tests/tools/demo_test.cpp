// `rocklab demo` as a user runs it: the figure 7 table and the two
// trajectory files. Oracle: the uplift time computed here from the
// documented table motion (docs/commands.md, `--excitation`: u(t) = U A(t - t_c)
// sin(2 pi f (t - start)), A the Hanning window of docs/errata.md item 11) and the
// rest criterion of docs/errata.md item 6 (uplift when |u''| > g tan(alpha)), by a
// fine scan and bisection of a numerical second derivative written in this
// test, not by model/excitation.cpp; both models share the rest logic, so
// both must uplift then. Files: 8 s at 200 Hz, so 1601 rows (t = 0 .. 8 s).
#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/tools/run_cli.h"
#include "common/units.h"

namespace rocklab::tools {
namespace {

using ::rocklab::common::kPi;  // one pi for the tests a unity batch shares

// Figure 7's table displacement, m (amp 6 mm, 3.3 Hz, 4 s from 0.5 s).
double Displacement(double t) {
  const double amp = 0.006, f = 3.3, start = 0.5, duration = 4.0, half = duration / 2;
  if (t < start || t > start + duration) return 0.0;
  const double window = 0.5 * (1 + std::cos(kPi * (t - start - half) / half));
  return amp * window * std::sin(2 * kPi * f * (t - start));
}

// Second derivative by a central difference, m/s^2 (h = 1e-4 s: truncation
// ~ h^2 u''''/12 ~ 1e-6 m/s^2, rounding ~ 1e-16 * 6e-3 / h^2 ~ 1e-10).
double Acceleration(double t) {
  const double h = 1e-4;
  return (Displacement(t + h) - 2 * Displacement(t) + Displacement(t - h)) / (h * h);
}

double FirstUplift(double alpha) {
  const double threshold = 9.81 * std::tan(alpha);
  double t = 0.5;
  while (std::abs(Acceleration(t)) <= threshold) t += 1e-4;
  double lo = t - 1e-4, hi = t;
  for (int i = 0; i < 60; ++i) {
    const double mid = (lo + hi) / 2;
    (std::abs(Acceleration(mid)) > threshold ? hi : lo) = mid;
  }
  return hi;
}

TEST(Demo, PrintsTheFigure7TableAndWritesBothTrajectories) {
  const std::string dir = test::ScratchDir("demo");
  const test::CliResult r = test::RunCli({"demo", "--out-dir", dir});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const double uplift = FirstUplift(0.235);
  std::printf("uplift from the table motion: %.5f s\n", uplift);
  for (const char* model : {"housner", "complex"}) {
    // The row: model, uplift_s, peak_theta_deg, peak_s, impacts, final, trajectory.
    const std::size_t at = r.out.find(std::string("\n") + model + " ");
    ASSERT_NE(at, std::string::npos) << r.out;
    std::istringstream row(r.out.substr(at + 1));
    std::string name, final_regime, path;
    double uplift_s = 0, peak_deg = 0, peak_s = 0;
    int impacts = 0;
    row >> name >> uplift_s >> peak_deg >> peak_s >> impacts >> final_regime >> path;
    ASSERT_TRUE(row) << r.out;
    // TOLERANCE: the table prints 4 decimals (5e-5 s), the model's event
    // location adds less than 1e-6 s.
    EXPECT_NEAR(uplift_s, uplift, 6e-5) << model;
    EXPECT_GT(impacts, 10) << model;  // the paper's figure 7 rocks through many impacts
    EXPECT_GT(peak_s, uplift_s) << model;
    EXPECT_EQ(path, dir + "/" + model + ".csv");
    const std::string csv = test::ReadFile(path);
    EXPECT_EQ(csv.rfind("time,theta,theta_dot\n", 0), 0u) << model;
    int rows = 0;
    for (char c : csv) rows += c == '\n';
    EXPECT_EQ(rows - 1, 1601) << model;
    // Its provenance beside it (docs/provenance.md): no input file, the
    // built-in scenario named instead, with the figure's parameters.
    const std::string sidecar = test::ReadFile(dir + "/" + model + ".provenance.csv");
    EXPECT_EQ(sidecar.rfind("key,value\n", 0), 0u) << sidecar;
    EXPECT_NE(sidecar.find("\"command\",\"" + std::string(ROCKLAB_BINARY) + " demo --out-dir " + dir + "\""),
              std::string::npos)
        << sidecar;
    EXPECT_NE(sidecar.find(std::string("\"scenario\",\"figure 7, model ") + model +
                           ", alpha 0.235 rad, p 3.884 rad/s, mu 0.937, hanning:amp=0.006,freq=3.3,duration=4,start=0.5, "
                           "8 s at 200 Hz\""),
              std::string::npos)
        << sidecar;
    EXPECT_EQ(sidecar.find("source_1"), std::string::npos) << sidecar;
  }
}

TEST(Demo, AnOutDirThatCannotBeMadeIsAUsageError) {
  const std::string dir = test::ScratchDir("demo_bad");
  test::WriteFile(dir + "/file", "x");
  const test::CliResult r = test::RunCli({"demo", "--out-dir", dir + "/file/sub"});
  EXPECT_EQ(r.exit_code, 2) << r.out << r.err;
  EXPECT_NE(r.err.find("--out-dir"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace rocklab::tools
