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

constexpr double kPi = 3.14159265358979323846;

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

// True when the complex model integrates eq. (10) at time_s, not its l -> 0
// limit below the resolution floor (model/complex.cpp), which keeps psi on a
// multiple of pi; eq. (10) turns psi at l/chi^2 > 0 all the time.
bool ComplexResolvedAt(const Scenario& s, const ModelOptions& options, double time_s) {
  auto model = RockingModel::Create(ModelKind::kComplex, s.params, options);
  const auto excitation = ParseExcitation(s.excitation);
  model->Reset(0.0, 0.0, 0.0);
  model->AdvanceTo(time_s, *excitation);
  const double psi = model->state().psi;
  return model->state().regime == Regime::kRocking && std::abs(psi - kPi * std::round(psi / kPi)) > 1e-9;
}

// ORACLE: Housner. Uplift is decided by the same rest-regime root finding in
// both models: TOLERANCE 1e-9 s (CVODE's root tolerance ~1e-13 s; the two
// integrators take different steps). The first excursion (peak at 0.14 s) is
// below the complex formulation's resolution floor at l = 3e-5 and is
// integrated in its l -> 0 limit (model/complex.cpp); eq. (10) takes over at
// 0.23 s and carries 99 % of the rocking time. So the peak |theta| is
// compared over [0, 20] s and over [1, 20] s, where every sample is eq. (10),
// with l = 3e-5 (the default 3e-4 leaves the complex model on a different
// long-term response after ~1 s: peak 0.041 rad at 7.7 s): TOLERANCE 10 %,
// for the O(l^(2/3)) regularisation of ~200 crossings (measured: 0.02461 vs
// 0.02461 over [0, 20] s, the first excursion, in the limit; 0.01453 vs
// 0.01428 over [1, 20] s, eq. (10), 1.7 %).
TEST(ScenarioTest, ComplexAgreesWithHousnerFigure8) {
  ModelOptions o;
  o.l = 3e-5;
  const Trajectory h = RunScenario(kFig8, ModelKind::kHousner);
  const Trajectory c = RunScenario(kFig8, ModelKind::kComplex, o);
  ASSERT_NE(FirstUplift(h), nullptr);
  ASSERT_NE(FirstUplift(c), nullptr);
  EXPECT_NEAR(FirstUplift(c)->time_s, FirstUplift(h)->time_s, 1e-9);
  for (double from_s : {0.0, 1.0}) {
    const double ph = Peak(h, from_s, 20.0), pc = Peak(c, from_s, 20.0);
    std::printf("fig8 peak |theta| over [%.0f, 20] s: housner %.5f complex %.5f\n", from_s, ph, pc);
    EXPECT_NEAR(pc / ph, 1.0, 0.10) << from_s;
  }
  EXPECT_TRUE(ComplexResolvedAt(kFig8, o, 1.0));
  EXPECT_TRUE(ComplexResolvedAt(kFig8, o, c.time_s[PeakIndex(c, 1.0, 20.0)]));
}

// ORACLE: Housner, uplift time as above (TOLERANCE 1e-9 s), and peak |theta|
// over [0, 8] s for l = 3e-4 (default), 3e-5 and 3e-6.
// The excitation is marginal (peak table acceleration 2.58 m/s^2 against
// g tan(alpha) = 2.35 m/s^2): Housner's block first chatters (~10 impacts at
// |theta_dot| 0.01-0.02 rad/s, energy ~1e-5 M g R) and is then pumped up to
// 0.0385 rad at 2.99 s. That chatter lies below the complex formulation's
// resolution floor (V_min ~ l^(2/3)) for every l tried (3e-4 .. 1e-10), where
// eq. (10) cannot follow it (before the l -> 0 hand-off the complex model went
// back to rest there: peak 0.026 rad at l = 3e-4, < 1e-3 rad at l <= 1e-4);
// the model integrates its l -> 0 limit there and eq. (10) from 2.87 s
// (l = 3e-4), 2.86 s (3e-5), 2.65 s (3e-6), i.e. through the peak excursion,
// which the test checks.
// TOLERANCE 3 %: Housner's own peak moves by that much for perturbations far
// below what the experiment or eq. (10) can resolve (measured: alpha +1e-4
// -3.3 %, mu -1e-3 -0.9 %, the whole state at 2.30 s scaled by 1 +- 1e-2
// -1.3 %/+0.2 %, by 1 +- 0.1 -7.6 %; rtol 1e-8..1e-12, max step 5e-4 s and a
// 1 ms shift of the excitation change < 0.03 %). Measured complex/Housner
// with the default hand-off: 0.9992, 0.9994, 0.9996 at the three l, and
// within 2 % for every l from 3e-4 down to 1e-7.
TEST(ScenarioTest, ComplexAgreesWithHousnerFigure7) {
  const Trajectory h = RunScenario(kFig7, ModelKind::kHousner);
  ASSERT_NE(FirstUplift(h), nullptr);
  const double ph = Peak(h, 0.0, 8.0);
  for (double l : {3e-4, 3e-5, 3e-6}) {
    ModelOptions o;
    o.l = l;
    const Trajectory c = RunScenario(kFig7, ModelKind::kComplex, o);
    ASSERT_NE(FirstUplift(c), nullptr);
    EXPECT_NEAR(FirstUplift(c)->time_s, FirstUplift(h)->time_s, 1e-9) << l;
    const std::size_t peak = PeakIndex(c, 0.0, 8.0);
    const double pc = std::abs(c.theta[peak]);
    std::printf("fig7 l %g: uplift %.6f s; peak |theta| housner %.5f complex %.5f at %.2f s (ratio %.4f)\n", l,
                FirstUplift(c)->time_s, ph, pc, c.time_s[peak], pc / ph);
    EXPECT_NEAR(pc / ph, 1.0, 0.03) << l;
    EXPECT_TRUE(ComplexResolvedAt(kFig7, o, c.time_s[peak])) << l;
  }
}

}  // namespace
}  // namespace rocklab::model
