// One scenario (rocklab simulate, synth, demo) as a library: the option
// checks, the forcing it builds, the rows it streams.
#include "pipeline/scenario.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>

#include "pipeline/option_error.h"
#include "tests/scratch.h"

namespace rocklab::pipeline {
namespace {

ScenarioOptions Block1() {
  ScenarioOptions o;
  o.alpha = 0.235;
  o.p = 3.884;
  o.mu = 0.937;
  o.duration_s = 1.0;
  o.rate_hz = 100.0;
  return o;
}

// Oracle: the documented sum (--excitation and --accel add) against the
// parts built on their own.
TEST(Scenario, ExcitationAndRecordAdd) {
  const std::string csv = test::ScratchDir("scenario_test") + "/" + "scenario_accel.csv";
  std::ofstream(csv) << "time,accel\n0,0\n1,2\n";
  ScenarioOptions o = Block1();
  o.excitations = {"sine:amp=0.006,freq=2,duration=3"};
  o.accel_csv = csv;
  const Scenario s = BuildScenario(o);
  const auto sine = model::ParseExcitation(o.excitations[0]);
  for (double t : {0.1, 0.45, 0.8}) {
    EXPECT_DOUBLE_EQ(s.forcing->TableAcceleration(t), sine->TableAcceleration(t) + 2.0 * t);
  }
  EXPECT_EQ(s.forcing_description, o.excitations[0] + " + accel:" + csv);
  std::remove(csv.c_str());
}

// Oracle: the documented errors, naming the option.
TEST(Scenario, BadValuesNameTheOption) {
  ScenarioOptions o = Block1();
  o.alpha = 2.0;
  try {
    BuildScenario(o);
    FAIL();
  } catch (const OptionError& e) {
    EXPECT_NE(std::string(e.what()).find("--alpha"), std::string::npos);
  }
  o = Block1();
  o.accel_csv = test::ScratchDir("scenario_test") + "/" + "no_such_accel.csv";
  try {
    BuildScenario(o);
    FAIL();
  } catch (const OptionError& e) {
    EXPECT_NE(std::string(e.what()).find("--accel: "), std::string::npos);
  }
}

// Oracle: rest is an equilibrium without table motion (theta stays 0), and
// the rows are t = k / rate for k = 0 .. floor(duration * rate).
TEST(Scenario, RestStaysAtRestOnTheRowClock) {
  ScenarioOptions o = Block1();
  Scenario s = BuildScenario(o);
  std::size_t k = 0;
  const RunSummary r = RunScenario(s, o, [&k, &o](double t, double theta, double theta_dot) {
    EXPECT_DOUBLE_EQ(t, static_cast<double>(k) / o.rate_hz);
    EXPECT_EQ(theta, 0.0);
    EXPECT_EQ(theta_dot, 0.0);
    ++k;
  });
  EXPECT_EQ(r.samples, 101u);
  EXPECT_EQ(k, 101u);
  EXPECT_EQ(r.impacts, 0);
  EXPECT_FALSE(r.uplift_time_s.has_value());
}

}  // namespace
}  // namespace rocklab::pipeline
