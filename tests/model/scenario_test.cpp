// The paper's figure 7 and figure 8 scenarios.
//
// Figure 7: block 1 of Table 2 (alpha 0.235, p 3.884 — ERRATA 10 —, mu
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
    GTEST_SKIP() << "regenerated " << GoldenPath(s);
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

double Peak(const Trajectory& t, double from_s, double to_s) {
  double peak = 0.0;
  for (std::size_t i = 0; i < t.time_s.size(); ++i) {
    if (t.time_s[i] >= from_s && t.time_s[i] <= to_s) peak = std::max(peak, std::abs(t.theta[i]));
  }
  return peak;
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

// ORACLE: Housner. Uplift is decided by the same rest-regime root finding in
// both models: TOLERANCE 1e-9 s (CVODE's root tolerance ~1e-13 s; the two
// integrators take different steps). Peak |theta|, over the first 0.5 s and
// the whole 20 s, with l = 3e-5 (the default 3e-4 leaves the complex model
// on a different attractor after ~1 s in this chaotic-looking transient):
// TOLERANCE 10 %, for the start offset alpha chi0 = 4.9e-4 rad of the
// complex formulation and its O(l^(2/3)) regularisation of ~200 impacts
// (measured: 0.5 s peaks 0.02346 vs 0.02461, 4.7 %).
TEST(ScenarioTest, ComplexAgreesWithHousnerFigure8) {
  ModelOptions o;
  o.l = 3e-5;
  const Trajectory h = RunScenario(kFig8, ModelKind::kHousner);
  const Trajectory c = RunScenario(kFig8, ModelKind::kComplex, o);
  ASSERT_NE(FirstUplift(h), nullptr);
  ASSERT_NE(FirstUplift(c), nullptr);
  EXPECT_NEAR(FirstUplift(c)->time_s, FirstUplift(h)->time_s, 1e-9);
  for (double to_s : {0.5, 20.0}) {
    const double ph = Peak(h, 0.0, to_s), pc = Peak(c, 0.0, to_s);
    std::printf("fig8 peak |theta| over [0, %.1f] s: housner %.5f complex %.5f\n", to_s, ph, pc);
    EXPECT_NEAR(pc / ph, 1.0, 0.10) << to_s;
  }
}

// ORACLE: Housner, uplift time as above (TOLERANCE 1e-9 s).
// The peak is NOT compared: figure 7's excitation is marginal (peak table
// acceleration 2.58 m/s^2 against g tan(alpha) = 2.35 m/s^2) and Housner's
// response begins with ~10 chatter impacts of |theta_dot| ~ 0.01-0.02 rad/s.
// Their energy lies below the complex formulation's regularisation floor
// (the minimum of its effective potential, ~l^(2/3)) for any l >= 3e-6, so
// the complex model goes back to rest there while Housner's block is pumped
// up to 0.038 rad; measured complex peak 0.026 rad at l = 3e-4, under 1e-3
// rad at l = 3e-5. See the report of the model work.
TEST(ScenarioTest, ComplexAgreesWithHousnerFigure7UpliftTime) {
  const Trajectory h = RunScenario(kFig7, ModelKind::kHousner);
  const Trajectory c = RunScenario(kFig7, ModelKind::kComplex);
  ASSERT_NE(FirstUplift(h), nullptr);
  ASSERT_NE(FirstUplift(c), nullptr);
  EXPECT_NEAR(FirstUplift(c)->time_s, FirstUplift(h)->time_s, 1e-9);
  std::printf("fig7 uplift %.6f s; peak |theta| housner %.5f complex %.5f (not compared)\n",
              FirstUplift(h)->time_s, Peak(h, 0, 8), Peak(c, 0, 8));
}

}  // namespace
}  // namespace rocklab::model
