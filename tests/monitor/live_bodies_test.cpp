// LiveState with an assembly: RL_BODIES (block_state2_t), RL_MODEL_<name>
// as model_state4_t and RL_COMPAREBODIES_<name> (comparison3_t) shown one
// series per body; a single block's document keeps its keys. Oracles: the
// messages fed (values chosen here) and the degree (180/pi per rad).
#include "monitor/live_state.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "rocklab/block_state2_t.hpp"
#include "rocklab/comparison3_t.hpp"
#include "rocklab/model_state4_t.hpp"
#include "tests/tools/lcm_messages.h"

namespace rocklab::monitor {
namespace {

using nlohmann::json;

constexpr double kDegPerRadHere = 180.0 / 3.14159265358979323846;

template <class Msg>
bool FeedBodies(LiveState& s, const std::string& channel, const Msg& m) {
  std::vector<std::uint8_t> b(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(b.data(), 0, static_cast<int>(b.size()));
  return s.Ingest(channel, b.data(), static_cast<int>(b.size()));
}

rocklab::block_state2_t MeasuredBodies(std::int64_t utime, double lower, double upper) {
  rocklab::block_state2_t m{};
  m.utime = utime;
  m.nbodies = 2;
  m.theta = {lower, upper};
  m.theta_dot = m.theta_mirror = m.theta_camera = m.sliding = m.jump = m.twist = m.out_of_plane = {0, 0};
  m.leds_used = {4, 4};
  m.flags = {0, 0};
  return m;
}

rocklab::model_state4_t ModelBodies(std::int64_t utime, double lower, double upper) {
  rocklab::model_state4_t m{};
  m.utime = utime;
  m.name = "stack";
  m.model = "housner";
  m.nbodies = 2;
  m.theta = {lower, upper};
  m.theta_dot = m.chi = m.psi = {0, 0};
  m.regime = {1, 1};
  m.alpha = {0.3, 0.2};
  m.p = {2.0, 1.5};
  m.mu = {0.9, 0.8};
  m.mode = "RC";
  return m;
}

// Oracle: a two-body test at 1 kHz for 0.5 s (measured lower 0.01 rad,
// upper 0.02 rad; the model 0.011 and 0.018 rad): the page gets per body
// the measured and the model's theta in degrees, the variant's own theta
// and parameters are body 0's, and the newest comparison3_t per body.
TEST(LiveStateBodies, ShowsEveryBodyOfAnAssembly) {
  LiveState s;
  for (int k = 0; k < 500; ++k) {
    const std::int64_t u = 1'000'000 + 1000 * k;
    EXPECT_TRUE(FeedBodies(s, "RL_THETA", test::Theta(u, 0.01)));
    EXPECT_TRUE(FeedBodies(s, "RL_BODIES", MeasuredBodies(u, 0.01, 0.02)));
    EXPECT_TRUE(FeedBodies(s, "RL_MODEL_stack", ModelBodies(u, 0.011, 0.018)));
  }
  rocklab::comparison3_t c{};
  c.utime = 1'000'000 + 1000 * 499;
  c.name = "stack";
  c.nbodies = 2;
  c.error = {1e-3, -2e-3};
  c.rms_window = c.rms_total = {1e-3, 2e-3};
  c.nrms = {0.1, 0.1};
  c.peak_error = c.impact_timing_error = {std::nan(""), std::nan("")};
  c.correlation = {1, 1};
  c.valid = {1, 0};
  c.samples = 500;
  c.mode_model = "RC";
  c.mode_measured = "RR";
  c.mode_rest_rad = 2e-3;
  c.mode_agreement = 0.25;
  c.mode_samples = 400;
  EXPECT_TRUE(FeedBodies(s, "RL_COMPAREBODIES_stack", c));

  const json snap = s.Snapshot();
  const json& measured = snap.at("bodies").at("measured");
  ASSERT_EQ(measured.size(), 2u);
  EXPECT_EQ(measured[0].at("t").size(), 50u);  // 0.5 s at the default 100 points/s
  EXPECT_DOUBLE_EQ(measured[1].at("theta_deg")[0].get<double>(), 0.02 * kDegPerRadHere);
  ASSERT_EQ(snap.at("variants").size(), 1u);
  const json& v = snap.at("variants")[0];
  EXPECT_EQ(v.at("name"), "stack");
  EXPECT_EQ(v.at("alpha").get<double>(), 0.3);  // body 0's
  EXPECT_DOUBLE_EQ(v.at("theta").at("theta_deg")[0].get<double>(), 0.011 * kDegPerRadHere);
  ASSERT_EQ(v.at("bodies").size(), 2u);
  EXPECT_DOUBLE_EQ(v.at("bodies")[1].at("theta_deg")[0].get<double>(), 0.018 * kDegPerRadHere);
  const json& latest = v.at("bodies_latest");
  EXPECT_EQ(latest.at("rms_total")[1].get<double>(), 2e-3);
  EXPECT_TRUE(latest.at("peak_error")[0].is_null());
  EXPECT_EQ(latest.at("valid")[1], false);
  EXPECT_EQ(latest.at("mode_model"), "RC");
  EXPECT_EQ(latest.at("mode_measured"), "RR");
  EXPECT_EQ(latest.at("mode_agreement").get<double>(), 0.25);
  EXPECT_EQ(latest.at("mode_samples").get<int>(), 400);
  EXPECT_EQ(snap.at("counters").at("decode_errors").at("RL_MODEL_stack").get<int>(), 0);
}

// The contract: a single block (model_state3_t, no RL_BODIES) has no
// "bodies" anywhere; a model_state4_t of one body is shown as the
// model_state3_t it carries.
TEST(LiveStateBodies, ASingleBlockDocumentIsUnchanged) {
  LiveState a, b;
  for (int k = 0; k < 100; ++k) {
    const std::int64_t u = 1'000'000 + 1000 * k;
    FeedBodies(a, "RL_THETA", test::Theta(u, 0.01));
    FeedBodies(b, "RL_THETA", test::Theta(u, 0.01));
    auto m3 = test::Model("one", u, 0.012);
    FeedBodies(a, "RL_MODEL_one", m3);
    rocklab::model_state4_t m4{};
    m4.utime = u;
    m4.name = m3.name;
    m4.model = m3.model;
    m4.nbodies = 1;
    m4.theta = {m3.theta};
    m4.theta_dot = m4.chi = m4.psi = {0};
    m4.regime = {0};
    m4.alpha = {m3.alpha};
    m4.p = {m3.p};
    m4.mu = {m3.mu};
    m4.equations = m3.equations;
    FeedBodies(b, "RL_MODEL_one", m4);
  }
  json ja = a.Snapshot(), jb = b.Snapshot();
  EXPECT_FALSE(ja.contains("bodies"));
  EXPECT_FALSE(ja.at("variants")[0].contains("bodies"));
  // The documents differ only in the channel's byte count (another type).
  ja.erase("counters");
  jb.erase("counters");
  EXPECT_EQ(ja.dump(), jb.dump());
}

}  // namespace
}  // namespace rocklab::monitor
