// The paper's figure 7 and figure 8 scenarios.
//
// Figure 7: block 1 of Table 2 (alpha 0.235, p 3.884 — docs/errata.md item 10 —, mu
// 0.937), table displacement hanning:amp=0.006,freq=3.3,duration=4,start=0.5,
// simulated over [0, 8] s. Figure 8: block 2 (alpha 0.168, p 3.767, mu
// 0.942), sine:amp=0.006,freq=5,duration=20,start=0, over [0, 20] s.
// Both from rest, output at 100 Hz.
//
// Housner's response is pinned by golden CSVs (golden/housner_fig7.csv,
// golden/housner_fig8.csv, columns time (s), theta (rad), theta_dot (rad/s)).
// To regenerate them after a deliberate change of the model:
//   ROCKLAB_REGENERATE_GOLDEN=1 ./model_scenario_test
// (rewrites the files in the source tree; review the diff before committing).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>

#include "model/rocking_model.h"
#include "tests/skip.h"

namespace rocklab::model {
namespace {


struct Scenario {
  const char* name;
  BlockParams params;
  const char* excitation;
  double duration_s;
};

const Scenario kFig7{"fig7", {0.235, 3.884, 0.937}, "hanning:amp=0.006,freq=3.3,duration=4,start=0.5", 8.0};
const Scenario kFig8{"fig8", {0.168, 3.767, 0.942}, "sine:amp=0.006,freq=5,duration=20,start=0", 20.0};

Trajectory RunScenario(const Scenario& s, ModelKind kind, const ModelOptions& options = {}) {
  auto model = RockingModel::Create(kind, s.params, options);
  const auto excitation = ParseExcitation(s.excitation);
  return Simulate(*model, *excitation, 0.0, 0.0, 0.0, s.duration_s, 100.0);
}

std::string GoldenPath(const Scenario& s) {
  return std::string(ROCKLAB_SOURCE_DIR) + "/tests/model/golden/housner_" + s.name + ".csv";
}

void WriteGolden(const Scenario& s, const Trajectory& t) {
  std::ofstream out(GoldenPath(s));
  ASSERT_TRUE(out) << GoldenPath(s);
  out << "time,theta,theta_dot\n";
  char line[128];
  for (std::size_t i = 0; i < t.time_s.size(); ++i) {
    std::snprintf(line, sizeof line, "%.2f,%.12e,%.12e\n", t.time_s[i], t.theta[i], t.theta_dot[i]);
    out << line;
  }
}

// ORACLE: the golden file written by this code at a reviewed commit.
// TOLERANCE: theta 1e-6 rad, theta_dot 1e-5 rad/s. Both responses are
// well-conditioned (figure 8 settles on a stable period-2 orbit, one impact
// per half forcing period): re-running with rtol 1e-11 / max step 5e-4 s or
// rtol 1e-9 changed theta by at most 2.3e-8 rad (figure 7) and 1.4e-10 rad
// (figure 8); 1e-6 leaves a factor ~40 for other compilers and libm, and is
// far below anything visible on the paper's plots (degrees).
void CheckGolden(const Scenario& s) {
  const Trajectory t = RunScenario(s, ModelKind::kHousner);
  if (const char* env = std::getenv("ROCKLAB_REGENERATE_GOLDEN"); env && std::string(env) == "1") {
    WriteGolden(s, t);
    ROCKLAB_SKIP("regenerated " + GoldenPath(s) + " (no check: a regenerated golden file cannot fail)");
  }
  std::ifstream in(GoldenPath(s));
  ASSERT_TRUE(in) << "missing " << GoldenPath(s) << " (ROCKLAB_REGENERATE_GOLDEN=1 writes it)";
  std::string line;
  std::getline(in, line);
  ASSERT_EQ(line, "time,theta,theta_dot");
  std::size_t i = 0;
  double worst_theta = 0.0;
  while (std::getline(in, line)) {
    ASSERT_LT(i, t.time_s.size());
    double time = 0, theta = 0, theta_dot = 0;
    ASSERT_EQ(std::sscanf(line.c_str(), "%lf,%lf,%lf", &time, &theta, &theta_dot), 3) << line;
    EXPECT_NEAR(t.time_s[i], time, 1e-9);
    EXPECT_NEAR(t.theta[i], theta, 1e-6) << s.name << " t " << time;
    EXPECT_NEAR(t.theta_dot[i], theta_dot, 1e-5) << s.name << " t " << time;
    worst_theta = std::max(worst_theta, std::abs(t.theta[i] - theta));
    ++i;
  }
  EXPECT_EQ(i, t.time_s.size());
  std::printf("%s: max |theta - golden| = %.3e rad over %zu samples\n", s.name, worst_theta, i);
}

const ModelEvent* FirstUplift(const Trajectory& t) {
  for (const auto& e : t.events) {
    if (e.kind == EventKind::kUplift) return &e;
  }
  return nullptr;
}

// ORACLE: the excitations must lift the blocks at all (peak |u_g''| above
// g tan(alpha)), otherwise the scenarios test nothing.
TEST(ScenarioTest, ExcitationsExceedTheUpliftThreshold) {
  for (const Scenario* s : {&kFig7, &kFig8}) {
    const auto e = ParseExcitation(s->excitation);
    double peak = 0.0;
    for (double t = 0.0; t <= s->duration_s; t += 1e-4) peak = std::max(peak, std::abs(e->TableAcceleration(t)));
    EXPECT_GT(peak, kGravity * std::tan(s->params.alpha)) << s->name;
  }
}

TEST(ScenarioTest, HousnerFigure7Golden) { CheckGolden(kFig7); }
TEST(ScenarioTest, HousnerFigure8Golden) { CheckGolden(kFig8); }

// The sample where |theta| peaks over [from_s, to_s], or the first sample.
std::size_t PeakIndex(const Trajectory& t, double from_s, double to_s) {
  std::size_t best = 0;
  for (std::size_t i = 0; i < t.time_s.size(); ++i) {
    if (t.time_s[i] >= from_s && t.time_s[i] <= to_s && std::abs(t.theta[i]) > std::abs(t.theta[best])) best = i;
  }
  return best;
}

double Peak(const Trajectory& t, double from_s, double to_s) { return std::abs(t.theta[PeakIndex(t, from_s, to_s)]); }

int Impacts(const Trajectory& t) {
  int n = 0;
  for (const auto& e : t.events) n += e.kind == EventKind::kImpact;
  return n;
}

// ORACLE: an independent exact integration of Housner's equations (scipy,
// tolerances 1e-10): figure 7 peak |theta| 0.038490 rad, figure 8
// 0.024721 rad and 199 impacts; rocklab's Housner model sampled at 1 kHz
// must give them (TOLERANCE 5e-6 rad: the 1 kHz sampling of the peak,
// theta'' h^2 / 8 < 4e-7 rad, and the printed digits). The complex model at
// its defaults (eq. (10) throughout, l = 1e-14) must meet Housner's limit
// peak within 3x the measured (0.25 % for figure 7,
// 0.024 % for figure 8), the same impact count, the same uplift time
// (the same rest-regime root finding: 1e-9 s), eq. (10) for all of the
// rocking time. Measured: figure 7 -0.09 %, 92 against 92 impacts; figure 8
// -0.01 %, 199 against 199 (docs/models.md, for other l). Figure 7 is
// the sensitive one: Housner's own peak moves by 3 % for perturbations of
// 1e-4 in alpha; at l = 1e-9 the complex model misses it by 1.2 %.
void CheckComplexAgainstHousner(const Scenario& s, double oracle_peak, int oracle_impacts, double peak_tol) {
  auto housner = RockingModel::Create(ModelKind::kHousner, s.params);
  auto complex = RockingModel::Create(ModelKind::kComplex, s.params);
  const auto excitation = ParseExcitation(s.excitation);
  const Trajectory h = Simulate(*housner, *excitation, 0.0, 0.0, 0.0, s.duration_s, 1000.0);
  const Trajectory c = Simulate(*complex, *excitation, 0.0, 0.0, 0.0, s.duration_s, 1000.0);
  const double ph = Peak(h, 0.0, s.duration_s), pc = Peak(c, 0.0, s.duration_s);
  std::printf("%s: peak |theta| housner %.6f complex %.6f (%+.3f %%), impacts %d / %d, eq. (10) %.3f\n", s.name, ph,
              pc, 100 * (pc / ph - 1), Impacts(h), Impacts(c), complex->solver_stats().eq10_fraction);
  EXPECT_NEAR(ph, oracle_peak, 5e-6);
  EXPECT_EQ(Impacts(h), oracle_impacts);
  ASSERT_NE(FirstUplift(h), nullptr);
  ASSERT_NE(FirstUplift(c), nullptr);
  EXPECT_NEAR(FirstUplift(c)->time_s, FirstUplift(h)->time_s, 1e-9);
  EXPECT_NEAR(pc / ph, 1.0, peak_tol);
  EXPECT_EQ(Impacts(c), Impacts(h));
  EXPECT_EQ(complex->solver_stats().eq10_fraction, 1.0);
}

// Figure 7's 92 impacts: the RK4 reference's count (oracle_test.cpp,
// ReferenceReproducesTheQuotedFigures; the paper prints none).
TEST(ScenarioTest, ComplexAgreesWithHousnerFigure8) { CheckComplexAgainstHousner(kFig8, 0.024721, 199, 2.4e-4); }
TEST(ScenarioTest, ComplexAgreesWithHousnerFigure7) { CheckComplexAgainstHousner(kFig7, 0.038490, 92, 2.5e-3); }

}  // namespace
}  // namespace rocklab::model
