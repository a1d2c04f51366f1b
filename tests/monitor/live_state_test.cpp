// LiveState: decoding by channel name, degrees, decimation, bounded memory,
// flag intervals, stale intervals from events, decode-error counters and
// incremental updates. Oracles: the messages fed (values chosen here), the
// definition of the degree (180/pi per rad), and the bounds the header states.
#include "monitor/live_state.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <string>
#include <thread>
#include <vector>

#include "rocklab/band_comparison_t.hpp"
#include "rocklab/block_state_t.hpp"
#include "rocklab/comparison2_t.hpp"
#include "rocklab/daq_config2_t.hpp"
#include "rocklab/event2_t.hpp"
#include "rocklab/health2_t.hpp"
#include "rocklab/model_band_t.hpp"
#include "rocklab/model_state3_t.hpp"
#include "rocklab/model_state_t.hpp"
#include "rocklab/table_state_t.hpp"
#include "tests/tools/lcm_messages.h"

namespace rocklab::monitor {
namespace {

using nlohmann::json;

constexpr double kDeg = 180.0 / 3.14159265358979323846;
constexpr std::int64_t kT0 = 5'000'000;  // us: the first sample's utime in these tests
const double kOpen = std::nan("");       // an interval's end while it is open

template <class Msg>
std::vector<std::uint8_t> Encode(const Msg& m) {
  std::vector<std::uint8_t> b(static_cast<std::size_t>(m.getEncodedSize()));
  EXPECT_EQ(m.encode(b.data(), 0, static_cast<int>(b.size())), static_cast<int>(b.size()));
  return b;
}

template <class Msg>
bool Feed(LiveState& s, const std::string& channel, const Msg& m) {
  const auto b = Encode(m);
  return s.Ingest(channel, b.data(), static_cast<int>(b.size()));
}

using test::Model;
using test::Theta;

rocklab::comparison2_t Compare(const std::string& name, std::int64_t utime, double error) {
  rocklab::comparison2_t m{};
  m.utime = utime;
  m.name = name;
  m.error = error;
  m.rms_window = 0.25 * error;
  m.window_s = 2.0;
  m.rms_total = 0.012345678901234567;
  m.nrms = 0.2718281828459045;
  m.peak_error = -1.5e-3;
  m.impact_timing_error = 2.5e-3;
  m.correlation = 0.99876543210987654;
  m.valid = true;
  m.samples = 6996;
  return m;
}

rocklab::event2_t Event(std::int64_t utime, const std::string& source, std::int8_t kind,
                       double value) {
  rocklab::event2_t m{};
  m.utime = utime;
  m.source = source;
  m.kind = kind;
  m.value = value;
  m.detail = "detail";
  return m;
}

// Theta, models and comparisons at 1 kHz from kT0 for `seconds`.
void FeedRun(LiveState& s, double seconds, std::int64_t t0 = kT0) {
  const auto n = static_cast<std::int64_t>(seconds * 1000);
  for (std::int64_t k = 0; k < n; ++k) {
    const std::int64_t u = t0 + k * 1000;
    const double theta = 0.01 * std::sin(2e-3 * static_cast<double>(k));
    Feed(s, "RL_THETA", Theta(u, theta));
    Feed(s, "RL_MODEL_a", Model("a", u, theta + 1e-4));
    Feed(s, "RL_MODEL_b", Model("b", u, theta - 1e-4));
    if (k % 50 == 0) {  // RL_COMPARE at 20 Hz
      Feed(s, "RL_COMPARE_a", Compare("a", u, 1e-4));
      Feed(s, "RL_COMPARE_b", Compare("b", u, -1e-4));
    }
  }
}

// One flag interval; end NaN: still open (null).
void ExpectInterval(const json& iv, const std::string& flag, const std::string& source,
                    double start_s, double end_s) {
  EXPECT_EQ(iv.at("flag"), flag) << iv.dump();
  EXPECT_EQ(iv.at("source"), source) << iv.dump();
  EXPECT_DOUBLE_EQ(iv.at("start").get<double>(), start_s) << iv.dump();
  if (std::isnan(end_s)) {
    EXPECT_TRUE(iv.at("end").is_null()) << iv.dump();
  } else {
    EXPECT_DOUBLE_EQ(iv.at("end").get<double>(), end_s) << iv.dump();
  }
}

const json& VariantNamed(const json& snap, const std::string& name) {
  for (const json& v : snap.at("variants")) {
    if (v.at("name") == name) return v;
  }
  static const json none;
  ADD_FAILURE() << "no variant " << name;
  return none;
}

// Oracle: the channel contract (docs/channels.md). RL_MODEL_<name> from the model node
// (model_state3_t) shows which equations produced the newest sample; a log
// written before it carries model_state_t on the same channels: still shown
// (same theta in degrees, parameters), "equations" null (it does not say).
TEST(LiveState, ShowsModelState2EquationsAndStillTheOldModelState) {
  LiveState s;
  ASSERT_TRUE(Feed(s, "RL_THETA", Theta(kT0, 0.1)));
  rocklab::model_state3_t now = Model("new", kT0, 0.2);
  now.model = "complex";
  now.equations = rocklab::model_state3_t::EQUATIONS_EQ10;
  EXPECT_TRUE(Feed(s, "RL_MODEL_new", now));
  EXPECT_TRUE(Feed(s, "RL_MODEL_old", test::OldModel("old", kT0, 0.3)));
  const json snap = s.Snapshot();
  const json& v2 = VariantNamed(snap, "new");
  EXPECT_EQ(v2.at("equations"), "eq10");
  EXPECT_EQ(v2.at("model"), "complex");
  const json& v1 = VariantNamed(snap, "old");
  EXPECT_TRUE(v1.at("equations").is_null());
  EXPECT_EQ(v1.at("model"), "housner");
  EXPECT_EQ(v1.at("alpha").get<double>(), 0.235);
  ASSERT_EQ(v1.at("theta").at("theta_deg").size(), 1u);
  EXPECT_DOUBLE_EQ(v1.at("theta").at("theta_deg")[0].get<double>(), 0.3 * kDeg);
  EXPECT_EQ(snap.at("counters").at("decode_errors").value("RL_MODEL_old", std::int64_t{0}), 0);
}

TEST(LiveState, ThetaAndModelsInDegreesAgainstTimeFromTheFirstSample) {
  LiveState s;
  EXPECT_TRUE(Feed(s, "RL_THETA", Theta(kT0, 0.1)));
  EXPECT_TRUE(Feed(s, "RL_THETA", Theta(kT0 + 20'000, -0.2)));
  rocklab::model_state3_t model = Model("fit", kT0 + 20'000, 0.3);
  model.model = "complex";
  model.equations = rocklab::model_state3_t::EQUATIONS_EQ10;
  model.l = 0.5;
  EXPECT_TRUE(Feed(s, "RL_MODEL_fit", model));
  const json snap = s.Snapshot();
  EXPECT_EQ(snap.at("schema"), "rocklab.monitor.v1");
  EXPECT_TRUE(snap.at("full").get<bool>());
  EXPECT_EQ(snap.at("t0_utime").get<std::int64_t>(), kT0);
  EXPECT_DOUBLE_EQ(snap.at("t_latest").get<double>(), 0.02);
  const json& m = snap.at("measured");
  ASSERT_EQ(m.at("t").size(), 2u);
  EXPECT_DOUBLE_EQ(m.at("t")[0].get<double>(), 0.0);
  EXPECT_DOUBLE_EQ(m.at("t")[1].get<double>(), 0.02);
  EXPECT_DOUBLE_EQ(m.at("theta_deg")[0].get<double>(), 0.1 * kDeg);
  EXPECT_DOUBLE_EQ(m.at("theta_deg")[1].get<double>(), -0.2 * kDeg);
  const json& v = VariantNamed(snap, "fit");
  EXPECT_EQ(v.at("model"), "complex");
  EXPECT_EQ(v.at("alpha").get<double>(), 0.235);
  EXPECT_EQ(v.at("p").get<double>(), 3.884);
  EXPECT_EQ(v.at("mu").get<double>(), 0.937);
  EXPECT_EQ(v.at("l").get<double>(), 0.5);
  ASSERT_EQ(v.at("theta").at("t").size(), 1u);
  EXPECT_DOUBLE_EQ(v.at("theta").at("t")[0].get<double>(), 0.02);
  EXPECT_DOUBLE_EQ(v.at("theta").at("theta_deg")[0].get<double>(), 0.3 * kDeg);
  EXPECT_TRUE(v.at("latest").is_null());  // no RL_COMPARE yet
}

// Oracle: live_state.h's definition, the table's peaks are max |u_g''| and
// max |u_g| over the window: samples whose largest magnitudes are negative
// (-3.5 m/s^2, -0.007 m against +2 m/s^2, +0.004 m) give 3.5 and 0.007,
// exactly (a peak without the absolute value survived the
// mutation check).
TEST(LiveState, TablePeaksAreOfTheMagnitude) {
  LiveState s;
  const double accel[] = {2.0, -3.5, 1.0}, disp[] = {0.004, -0.007, 0.001};
  for (int i = 0; i < 3; ++i) {
    rocklab::table_state_t m{};
    m.utime = kT0 + 1'000 * i;
    m.seq = i;
    m.acceleration = accel[i];
    m.displacement = disp[i];
    EXPECT_TRUE(Feed(s, "RL_TABLE", m));
  }
  const json table = s.Snapshot().at("table");
  EXPECT_EQ(table.at("samples").get<int>(), 3);
  EXPECT_EQ(table.at("peak_accel_mps2").get<double>(), 3.5);
  EXPECT_EQ(table.at("peak_disp_m").get<double>(), 0.007);
}

// The table's numbers must be the comparator's to the last bit.
TEST(LiveState, LatestComparisonExactlyAsReceivedAndSeriesInDegrees) {
  LiveState s;
  EXPECT_TRUE(Feed(s, "RL_COMPARE_fit", Compare("fit", kT0, 3e-3)));
  rocklab::comparison2_t last = Compare("fit", kT0 + 50'000, -2e-3);
  last.valid = false;
  last.samples = 51;
  EXPECT_TRUE(Feed(s, "RL_COMPARE_fit", last));
  const json snap = s.Snapshot();
  const json& v = VariantNamed(snap, "fit");
  EXPECT_TRUE(v.at("model").is_null());  // parameters unknown until an RL_MODEL_fit
  const json& l = v.at("latest");
  EXPECT_EQ(l.at("utime").get<std::int64_t>(), last.utime);
  EXPECT_EQ(l.at("error").get<double>(), last.error);
  EXPECT_EQ(l.at("rms_window").get<double>(), last.rms_window);
  EXPECT_EQ(l.at("window_s").get<double>(), last.window_s);
  EXPECT_EQ(l.at("rms_total").get<double>(), last.rms_total);
  EXPECT_EQ(l.at("nrms").get<double>(), last.nrms);
  EXPECT_EQ(l.at("peak_error").get<double>(), last.peak_error);
  EXPECT_EQ(l.at("impact_timing_error").get<double>(), last.impact_timing_error);
  EXPECT_EQ(l.at("correlation").get<double>(), last.correlation);
  EXPECT_FALSE(l.at("valid").get<bool>());
  EXPECT_EQ(l.at("samples").get<std::int64_t>(), 51);
  // The JSON text round-trips the doubles too (what the page parses).
  const json reparsed = json::parse(snap.dump());
  EXPECT_EQ(VariantNamed(reparsed, "fit").at("latest").at("correlation").get<double>(),
            last.correlation);
  const json& c = v.at("comparison");
  ASSERT_EQ(c.at("t").size(), 2u);
  EXPECT_DOUBLE_EQ(c.at("error_deg")[1].get<double>(), -2e-3 * kDeg);
  EXPECT_DOUBLE_EQ(c.at("rms_window_deg")[1].get<double>(), 0.25 * -2e-3 * kDeg);
}

// The whole-test figures of a variant ("whole"): peaks of |theta| over
// every message, not the decimated series (the peaks here fall between
// the 10 ms slots' first samples), and the impact timing errors counted
// once per matched crossing (the carried value changing; NaN before the
// first). Oracle: the values fed, by hand: peaks 0.05 (measured, at 3 ms)
// and 0.07 (model, |-0.07| at 4 ms); timing errors 0.01, -0.02, 0.03: 3,
// RMS sqrt((1e-4 + 4e-4 + 9e-4) / 3).
TEST(LiveState, WholeTestPeaksAndImpactTimingsFromEveryMessage) {
  LiveState s;
  const double measured[] = {0.01, 0.02, 0.03, -0.05, 0.04, 0.0};
  const double model[] = {0.0, 0.01, 0.02, 0.03, -0.07, 0.01};
  for (int i = 0; i < 6; ++i) {
    ASSERT_TRUE(Feed(s, "RL_THETA", Theta(kT0 + 1'000 * i, measured[i])));
    ASSERT_TRUE(Feed(s, "RL_MODEL_fit", Model("fit", kT0 + 1'000 * i, model[i])));
  }
  const double timing[] = {std::nan(""), 0.01, 0.01, -0.02, -0.02, 0.03};
  for (int i = 0; i < 6; ++i) {
    rocklab::comparison2_t c = Compare("fit", kT0 + 1'000 * i, 0.0);
    c.impact_timing_error = timing[i];
    ASSERT_TRUE(Feed(s, "RL_COMPARE_fit", c));
  }
  const json snap = s.Snapshot();
  const json& whole = VariantNamed(snap, "fit").at("whole");
  EXPECT_EQ(whole.at("peak_theta_measured").get<double>(), 0.05);
  EXPECT_EQ(whole.at("peak_theta").get<double>(), 0.07);
  EXPECT_EQ(VariantNamed(snap, "fit").at("theta").at("t").size(), 1u);  // the series kept one point
  EXPECT_EQ(whole.at("impact_timings").get<int>(), 3);
  EXPECT_NEAR(whole.at("impact_timing_rms").get<double>(), std::sqrt((1e-4 + 4e-4 + 9e-4) / 3), 1e-15);
  EXPECT_EQ(snap.at("units").at("peak_theta"), "rad");
  // No crossing matched (NaN throughout): 0 crossings, RMS null.
  LiveState none;
  rocklab::comparison2_t unmatched = Compare("fit", kT0, 0.0);
  unmatched.impact_timing_error = std::nan("");
  ASSERT_TRUE(Feed(none, "RL_COMPARE_fit", unmatched));
  const json none_snap = none.Snapshot();
  const json& w2 = VariantNamed(none_snap, "fit").at("whole");
  EXPECT_EQ(w2.at("impact_timings").get<int>(), 0);
  EXPECT_TRUE(w2.at("impact_timing_rms").is_null());
}

// Decimation keeps the first sample of every 1/series_rate_hz slot.
TEST(LiveState, SeriesAreDecimatedToTheSeriesRate) {
  LiveOptions o;
  o.series_rate_hz = 100;
  LiveState s(o);
  FeedRun(s, 1.0);  // 1000 samples at 1 kHz
  const json snap = s.Snapshot();
  const json& t = snap.at("measured").at("t");
  ASSERT_EQ(t.size(), 100u);
  for (std::size_t i = 0; i < t.size(); ++i) {
    EXPECT_NEAR(t[i].get<double>(), 0.01 * static_cast<double>(i), 1e-12) << i;
  }
  // Both variants on the same time grid as the measurement.
  EXPECT_EQ(VariantNamed(snap, "a").at("theta").at("t"), t);
  EXPECT_EQ(VariantNamed(snap, "b").at("theta").at("t"), t);
  EXPECT_EQ(VariantNamed(snap, "a").at("comparison").at("t").size(), 20u);  // 20 Hz < 100 Hz
}

// Bound (header): each series holds at most ceil(window_s * series_rate_hz)
// + 2 points; here 1 s at 100 Hz -> 102, after 100 s of 1 kHz input.
TEST(LiveState, SeriesStayBoundedAndCoverTheWindow) {
  LiveOptions o;
  o.window_s = 1.0;
  o.series_rate_hz = 100;
  LiveState s(o);
  EXPECT_EQ(s.SeriesCapacity(), 102u);
  FeedRun(s, 100.0);
  const json snap = s.Snapshot();
  const double t_latest = snap.at("t_latest").get<double>();
  EXPECT_DOUBLE_EQ(t_latest, 99.999);
  for (const json* series : {&snap.at("measured"), &VariantNamed(snap, "a").at("theta"),
                             &VariantNamed(snap, "b").at("theta")}) {
    const json& t = series->at("t");
    EXPECT_LE(t.size(), s.SeriesCapacity());
    EXPECT_GE(t.size(), 100u);  // the whole window is there
    EXPECT_GE(t.front().get<double>(), t_latest - 1.0);
    EXPECT_LT(t.front().get<double>(), t_latest - 0.98);
  }
  EXPECT_EQ(snap.at("counters").at("messages").at("RL_THETA").get<std::int64_t>(), 100000);
}

// An infinite window keeps the whole record, still decimated: 100 s at
// 100 Hz is 10000 points.
TEST(LiveState, InfiniteWindowKeepsTheWholeRecordDecimated) {
  LiveOptions o;
  o.window_s = std::numeric_limits<double>::infinity();
  LiveState s(o);
  EXPECT_EQ(s.SeriesCapacity(), 0u);
  FeedRun(s, 100.0);
  const json snap = s.Snapshot();
  EXPECT_TRUE(snap.at("window_s").is_null());
  EXPECT_EQ(snap.at("measured").at("t").size(), 10000u);
  EXPECT_EQ(VariantNamed(snap, "b").at("theta").at("t").size(), 10000u);
  EXPECT_DOUBLE_EQ(snap.at("measured").at("t").front().get<double>(), 0.0);
}

TEST(LiveState, EventsAreCappedAndCounted) {
  LiveOptions o;
  o.max_events = 10;
  LiveState s(o);
  for (int k = 0; k < 1000; ++k) {
    ASSERT_TRUE(Feed(s, "RL_EVENT", Event(kT0 + k * 1000, "fit", rocklab::event2_t::IMPACT, -0.1 * k)));
  }
  const json snap = s.Snapshot();
  const json& ev = snap.at("events");
  ASSERT_EQ(ev.size(), 10u);
  EXPECT_EQ(snap.at("counters").at("dropped").at("events").get<std::int64_t>(), 990);
  EXPECT_EQ(ev.back().at("kind"), "impact");
  EXPECT_EQ(ev.back().at("code").get<int>(), int{rocklab::event2_t::IMPACT});
  EXPECT_EQ(ev.back().at("source"), "fit");
  EXPECT_DOUBLE_EQ(ev.back().at("value").get<double>(), -0.1 * 999);
  EXPECT_DOUBLE_EQ(ev.back().at("t").get<double>(), 0.999);
  EXPECT_DOUBLE_EQ(ev.front().at("t").get<double>(), 0.990);  // the newest ten
}

// Sliding, jump and twist from block_state_t.flags become intervals: opened
// at the first flagged sample, closed at the first clear one.
TEST(LiveState, FlagsBecomeIntervals) {
  LiveState s;
  using B = rocklab::block_state_t;
  for (int k = 0; k <= 300; ++k) {
    std::int32_t flags = B::FLAG_NO_MIRROR;  // not shown as a band
    if (k >= 100 && k < 150) flags |= B::FLAG_SLIDING;
    if (k >= 120 && k < 130) flags |= B::FLAG_JUMP;
    if (k >= 280) flags |= B::FLAG_TWIST;
    Feed(s, "RL_THETA", Theta(kT0 + k * 10'000, 0.0, flags));
  }
  const json flags = s.Snapshot().at("flags");
  ASSERT_EQ(flags.size(), 3u) << flags.dump();
  ExpectInterval(flags[0], "sliding", "daq", 1.0, 1.5);
  ExpectInterval(flags[1], "jump", "daq", 1.2, 1.3);
  ExpectInterval(flags[2], "twist", "daq", 2.8, kOpen);  // still raised
}

TEST(LiveState, IntervalsAreCappedAndCounted) {
  LiveOptions o;
  o.max_intervals = 4;
  LiveState s(o);
  for (int k = 0; k < 100; ++k) {  // 50 sliding intervals
    Feed(s, "RL_THETA", Theta(kT0 + k * 1000, 0.0, k % 2 ? 0 : rocklab::block_state_t::FLAG_SLIDING));
  }
  const json snap = s.Snapshot();
  EXPECT_EQ(snap.at("flags").size(), 4u);
  EXPECT_EQ(snap.at("counters").at("dropped").at("intervals").get<std::int64_t>(), 46);
}

// STALE opens a "stale" interval for its source, RECOVERED from the same
// source closes it; a RECOVERED without an open stale interval (the DAQ's
// "sliding back within tolerance") changes no interval.
TEST(LiveState, StaleIntervalsFromEvents) {
  LiveState s;
  using E = rocklab::event2_t;
  Feed(s, "RL_THETA", Theta(kT0, 0.0));
  Feed(s, "RL_EVENT", Event(kT0 + 2'000'000, "daq", E::STALE, 1.2));
  Feed(s, "RL_EVENT", Event(kT0 + 2'500'000, "fit", E::RECOVERED, 0));
  Feed(s, "RL_EVENT", Event(kT0 + 2'600'000, "fit", E::STALE, 1.1));
  Feed(s, "RL_EVENT", Event(kT0 + 3'000'000, "daq", E::RECOVERED, 0));
  Feed(s, "RL_EVENT", Event(kT0 + 3'100'000, "daq", E::STALE, 1.0));  // a second one
  const json snap = s.Snapshot();
  const json& flags = snap.at("flags");
  ASSERT_EQ(flags.size(), 3u) << flags.dump();
  ExpectInterval(flags[0], "stale", "daq", 2.0, 3.0);
  ExpectInterval(flags[1], "stale", "fit", 2.6, kOpen);
  ExpectInterval(flags[2], "stale", "daq", 3.1, kOpen);
  EXPECT_EQ(snap.at("events").size(), 5u);
  EXPECT_EQ(snap.at("events")[0].at("kind"), "stale");
  EXPECT_EQ(snap.at("events")[1].at("kind"), "recovered");
}

// A source longer than the state keeps (its text is cut) still pairs its
// STALE and RECOVERED: one interval, closed.
TEST(LiveState, StaleIntervalOfALongSourceCloses) {
  LiveState s;
  using E = rocklab::event2_t;
  const std::string source(1000, 'm');
  Feed(s, "RL_THETA", Theta(kT0, 0.0));
  Feed(s, "RL_EVENT", Event(kT0 + 1'000'000, source, E::STALE, 1.0));
  Feed(s, "RL_EVENT", Event(kT0 + 1'500'000, source, E::STALE, 1.5));
  Feed(s, "RL_EVENT", Event(kT0 + 2'000'000, source, E::RECOVERED, 0));
  const json flags = s.Snapshot().at("flags");
  ASSERT_EQ(flags.size(), 1u) << flags.dump();
  EXPECT_DOUBLE_EQ(flags[0].at("end").get<double>(), 2.0);
}

TEST(LiveState, DecodeErrorsAreCountedPerChannelNeverThrown) {
  LiveState s;
  const std::vector<std::uint8_t> garbage{1, 2, 3, 4, 5};
  EXPECT_FALSE(s.Ingest("RL_THETA", garbage.data(), static_cast<int>(garbage.size())));
  EXPECT_FALSE(s.Ingest("RL_THETA", nullptr, 0));
  EXPECT_FALSE(s.Ingest("RL_HEALTH", nullptr, -5));
  // The right size, the wrong type: the fingerprint does not match.
  const auto theta = Encode(Theta(kT0, 0.1));
  EXPECT_FALSE(s.Ingest("RL_MODEL_fit", theta.data(), static_cast<int>(theta.size())));
  // Truncated.
  const auto model = Encode(Model("fit", kT0, 0.1));
  EXPECT_FALSE(s.Ingest("RL_MODEL_fit", model.data(), static_cast<int>(model.size()) - 3));
  // A string length of 0 (its NUL is part of the length): the generated
  // decoder throws on it.
  auto bad_string = Encode(Event(kT0, "daq", rocklab::event2_t::GAP, 1));
  for (int i = 24; i < 28; ++i) bad_string[static_cast<std::size_t>(i)] = 0;  // sender's length (after utime, seq)
  EXPECT_FALSE(s.Ingest("RL_EVENT", bad_string.data(), static_cast<int>(bad_string.size())));
  // A config claiming two billion channels in a short payload.
  rocklab::daq_config2_t config{};
  config.rig_name = "rig";
  config.calibration_id = "cal";
  auto huge = Encode(config);
  const std::size_t count_at = 24 + 4 + 4 + 4 + 4 + 8;  // after utime, seq, two strings, the rate
  huge[count_at] = 0x7f;
  EXPECT_FALSE(s.Ingest("RL_DAQ_CONFIG", huge.data(), static_cast<int>(huge.size())));
  huge[count_at] = 0xff;  // negative
  EXPECT_FALSE(s.Ingest("RL_DAQ_CONFIG", huge.data(), static_cast<int>(huge.size())));
  // Channels it does not show: ignored, counted as messages, not as errors.
  EXPECT_FALSE(s.Ingest("RL_RAW", garbage.data(), static_cast<int>(garbage.size())));
  EXPECT_FALSE(s.Ingest("OTHER_THETA", theta.data(), static_cast<int>(theta.size())));
  EXPECT_FALSE(s.Ingest("RL_MODEL_", model.data(), static_cast<int>(model.size())));

  const json c = s.Snapshot().at("counters");
  EXPECT_EQ(c.at("messages").at("RL_THETA").get<int>(), 2);
  EXPECT_EQ(c.at("decode_errors").at("RL_THETA").get<int>(), 2);
  EXPECT_EQ(c.at("decode_errors").at("RL_HEALTH").get<int>(), 1);
  EXPECT_EQ(c.at("decode_errors").at("RL_MODEL_fit").get<int>(), 2);
  EXPECT_EQ(c.at("decode_errors").at("RL_EVENT").get<int>(), 1);
  EXPECT_EQ(c.at("decode_errors").at("RL_DAQ_CONFIG").get<int>(), 2);
  EXPECT_EQ(c.at("messages").at("RL_RAW").get<int>(), 1);
  EXPECT_EQ(c.at("decode_errors").at("RL_RAW").get<int>(), 0);
  EXPECT_EQ(c.at("messages").at("OTHER_THETA").get<int>(), 1);
  EXPECT_EQ(c.at("decode_errors").at("RL_MODEL_").get<int>(), 0);
  // Nothing reached the state.
  const json snap = s.Snapshot();
  EXPECT_TRUE(snap.at("measured").at("t").empty());
  EXPECT_TRUE(snap.at("variants").empty());
  EXPECT_TRUE(snap.at("config").is_null());
}

TEST(LiveState, HealthPerNodeAndRigConfig) {
  LiveState s;
  rocklab::health2_t h{};
  h.utime = kT0;
  h.node = "daq";
  h.state = "running";
  h.rate_in_hz = 1000;
  h.count_in = 42;
  h.dropped = 3;
  h.lag_s = std::nan("");
  EXPECT_TRUE(Feed(s, "RL_HEALTH", h));
  h.state = "stopped";
  h.count_in = 43;
  EXPECT_TRUE(Feed(s, "RL_HEALTH", h));
  h.node = "compare";
  h.state = "stale";
  EXPECT_TRUE(Feed(s, "RL_HEALTH", h));
  rocklab::daq_config2_t config{};
  config.rig_name = "block1";
  config.calibration_id = "cal-2024";
  config.sample_rate_hz = 1000;
  config.num_channels = 1;
  config.channel_names = {"mirror_x"};
  config.channel_units = {"m"};
  config.channel_sensors = {"mirror_x"};
  config.gain = {1.0};
  config.offset = {0.0};
  config.alpha = 0.235;
  config.p = 3.884;
  config.mu = 0.937;
  EXPECT_TRUE(Feed(s, "RL_DAQ_CONFIG", config));

  const json snap = s.Snapshot();
  const json& health = snap.at("health");
  ASSERT_EQ(health.size(), 2u);  // by node name
  EXPECT_EQ(health[0].at("node"), "compare");
  EXPECT_EQ(health[1].at("node"), "daq");
  EXPECT_EQ(health[1].at("state"), "stopped");
  EXPECT_EQ(health[1].at("count_in").get<int>(), 43);
  EXPECT_EQ(health[1].at("dropped").get<int>(), 3);
  EXPECT_EQ(health[1].at("rate_in_hz").get<double>(), 1000.0);
  EXPECT_TRUE(health[1].at("lag_s").is_null());  // NaN
  const json& c = snap.at("config");
  EXPECT_EQ(c.at("rig_name"), "block1");
  EXPECT_EQ(c.at("calibration_id"), "cal-2024");
  EXPECT_EQ(c.at("sample_rate_hz").get<double>(), 1000.0);
  EXPECT_EQ(c.at("alpha").get<double>(), 0.235);
  EXPECT_EQ(c.at("p").get<double>(), 3.884);
  EXPECT_EQ(c.at("mu").get<double>(), 0.937);
}

// An update holds what came after the cursor; a page that applies updates
// holds what a snapshot holds.
TEST(LiveState, UpdatesCarryOnlyWhatCameAfterTheCursor) {
  LiveState s;
  FeedRun(s, 0.5);
  const json first = s.Snapshot();
  const auto cursor = first.at("cursor").get<std::uint64_t>();
  EXPECT_EQ(cursor, s.cursor());
  const json quiet = s.UpdateSince(cursor);
  EXPECT_FALSE(quiet.at("full").get<bool>());
  EXPECT_TRUE(quiet.at("measured").at("t").empty());
  EXPECT_EQ(quiet.at("cursor").get<std::uint64_t>(), cursor);

  FeedRun(s, 0.1, kT0 + 500'000);  // 0.5 .. 0.6 s
  Feed(s, "RL_EVENT", Event(kT0 + 550'000, "a", rocklab::event2_t::IMPACT, -0.2));
  const json update = s.UpdateSince(cursor);
  EXPECT_FALSE(update.at("full").get<bool>());
  const json& t = update.at("measured").at("t");
  ASSERT_EQ(t.size(), 10u);
  EXPECT_DOUBLE_EQ(t.front().get<double>(), 0.5);
  EXPECT_EQ(VariantNamed(update, "a").at("theta").at("t").size(), 10u);
  EXPECT_EQ(VariantNamed(update, "a").at("comparison").at("t").size(), 2u);
  ASSERT_EQ(update.at("events").size(), 1u);
  EXPECT_DOUBLE_EQ(update.at("events")[0].at("t").get<double>(), 0.55);
  EXPECT_GT(update.at("cursor").get<std::uint64_t>(), cursor);

  const json all = s.Snapshot();
  EXPECT_EQ(all.at("measured").at("t").size(), first.at("measured").at("t").size() + t.size());
}

// A flag closed after the cursor comes again in the update, with its end.
TEST(LiveState, UpdatesCarryIntervalsClosedAfterTheCursor) {
  LiveState s;
  Feed(s, "RL_THETA", Theta(kT0, 0.0, rocklab::block_state_t::FLAG_TWIST));
  const auto cursor = s.Snapshot().at("cursor").get<std::uint64_t>();
  Feed(s, "RL_THETA", Theta(kT0 + 1000, 0.0, 0));
  const json flags = s.UpdateSince(cursor).at("flags");
  ASSERT_EQ(flags.size(), 1u);
  ExpectInterval(flags[0], "twist", "daq", 0.0, 0.001);
}

// A sample clock going back by more than new_record_after_s (a replay
// started again) starts a new record: a reader's old cursor gets a full
// answer holding only the new record; a small step back is dropped, counted.
TEST(LiveState, ClockGoingBackStartsANewRecord) {
  LiveState s;
  FeedRun(s, 3.0);
  Feed(s, "RL_EVENT", Event(kT0 + 100'000, "a", rocklab::event2_t::UPLIFT, 2.5));
  const auto cursor = s.Snapshot().at("cursor").get<std::uint64_t>();
  EXPECT_TRUE(Feed(s, "RL_THETA", Theta(kT0 + 2'900'000, 0.0)));  // decoded ...
  EXPECT_EQ(s.Snapshot().at("counters").at("dropped").at("out_of_order").get<int>(), 1);  // ... dropped

  FeedRun(s, 0.2, kT0);  // the same test again from its start
  const json update = s.UpdateSince(cursor);
  EXPECT_TRUE(update.at("full").get<bool>());
  EXPECT_EQ(update.at("record").get<int>(), 2);
  EXPECT_EQ(update.at("t0_utime").get<std::int64_t>(), kT0);
  EXPECT_EQ(update.at("measured").at("t").size(), 20u);
  EXPECT_DOUBLE_EQ(update.at("t_latest").get<double>(), 0.199);
  EXPECT_TRUE(update.at("events").empty());
  EXPECT_EQ(update.at("variants").size(), 2u);
}

std::int64_t FarFromClock(const LiveState& s) {
  return s.Snapshot().at("counters").at("dropped").at("far_from_clock").get<std::int64_t>();
}

// Oracle: the fed run's own counts (100 Hz points of 1 kHz samples). One
// in-range RL_THETA far ahead and one far behind mid-test leave the record
// as it was, each counted; the test goes on in the same record. An event
// far ahead is kept but does not move the clock.
TEST(LiveState, AWildSampleMidTestIsCountedAndIgnored) {
  LiveState s;
  FeedRun(s, 3.0);
  EXPECT_TRUE(Feed(s, "RL_THETA", Theta(kT0 + 3'600'000'000, 0.5)));  // an hour ahead
  EXPECT_TRUE(Feed(s, "RL_THETA", Theta(kT0 - 2'000'000, 0.5)));      // 5 s back
  Feed(s, "RL_EVENT", Event(kT0 + 7'200'000'000, "daq", rocklab::event2_t::UPLIFT, 1.0));
  FeedRun(s, 1.0, kT0 + 3'000'000);
  const json snap = s.Snapshot();
  EXPECT_EQ(snap.at("record").get<int>(), 1);
  EXPECT_EQ(snap.at("t0_utime").get<std::int64_t>(), kT0);
  EXPECT_EQ(snap.at("measured").at("t").size(), 400u);
  EXPECT_DOUBLE_EQ(snap.at("t_latest").get<double>(), 3.999);
  EXPECT_EQ(snap.at("events").size(), 1u);
  EXPECT_EQ(FarFromClock(s), 2);
}

// Oracle: as above. A negative utime sent before the test does not become
// the origin: the test's samples agree among themselves, so they take the
// clock (nothing of theirs lost) and the stray one is counted.
TEST(LiveState, AStraySampleBeforeTheTestDoesNotMoveTheOrigin) {
  LiveState s;
  EXPECT_TRUE(Feed(s, "RL_THETA", Theta(-9'000'000'000'000'000, 0.5)));  // t ~ -9e9 s
  FeedRun(s, 2.0);
  const json snap = s.Snapshot();
  EXPECT_EQ(snap.at("t0_utime").get<std::int64_t>(), kT0);
  EXPECT_EQ(snap.at("measured").at("t").size(), 200u);
  EXPECT_DOUBLE_EQ(snap.at("measured").at("t").at(0).get<double>(), 0.0);
  EXPECT_DOUBLE_EQ(snap.at("t_latest").get<double>(), 1.999);
  EXPECT_EQ(FarFromClock(s), 1);
}

// Oracle: the counts fed. A gap forward in the sample clock (rows missing
// from the input) continues the record once the samples after it agree;
// they are all kept.
TEST(LiveState, AForwardGapKeepsTheRecord) {
  LiveState s;
  FeedRun(s, 2.0);
  FeedRun(s, 1.0, kT0 + 10'000'000);
  const json snap = s.Snapshot();
  EXPECT_EQ(snap.at("record").get<int>(), 1);
  EXPECT_EQ(snap.at("t0_utime").get<std::int64_t>(), kT0);
  EXPECT_EQ(snap.at("measured").at("t").size(), 300u);
  EXPECT_DOUBLE_EQ(snap.at("t_latest").get<double>(), 10.999);
  EXPECT_EQ(FarFromClock(s), 0);
}

// Oracle: RL_DAQ_CONFIG's contract (sent at a test's start on its clock).
// After a configuration on a far clock, the first sample that agrees with it
// starts the new record at once; without it, one sample is only held.
TEST(LiveState, ADaqConfigOnANewClockStartsTheNewRecordAtOnce) {
  for (const bool config : {false, true}) {
    LiveState s;
    FeedRun(s, 3.0);
    const std::int64_t t1 = kT0 + 100'000'000;
    if (config) {
      rocklab::daq_config2_t c{};
      c.utime = t1;
      c.rig_name = "block1";
      c.sample_rate_hz = 1000;
      EXPECT_TRUE(Feed(s, "RL_DAQ_CONFIG", c));
    }
    EXPECT_TRUE(Feed(s, "RL_THETA", Theta(t1, 0.0)));
    const json snap = s.Snapshot();
    EXPECT_EQ(snap.at("record").get<int>(), config ? 2 : 1) << "config " << config;
    EXPECT_EQ(snap.at("t0_utime").get<std::int64_t>(), config ? t1 : kT0) << "config " << config;
    EXPECT_EQ(snap.at("measured").at("t").size(), config ? 1u : 300u) << "config " << config;
  }
}

// Ingest on one thread while another reads, as the monitor runs. Oracle:
// every message counted, the reader's last update consistent.
TEST(LiveState, ConcurrentIngestAndUpdates) {
  LiveState s;
  std::thread writer([&s] { FeedRun(s, 5.0); });
  std::uint64_t cursor = 0;
  std::size_t points = 0;
  for (int i = 0; i < 200; ++i) {
    const json u = s.UpdateSince(cursor);
    if (u.at("full").get<bool>()) points = 0;
    points += u.at("measured").at("t").size();
    cursor = u.at("cursor").get<std::uint64_t>();
  }
  writer.join();
  points += s.UpdateSince(cursor).at("measured").at("t").size();
  EXPECT_EQ(points, 500u);  // 5 s at 100 Hz, none twice, none missed
  EXPECT_EQ(s.Snapshot().at("counters").at("messages").at("RL_MODEL_a").get<int>(), 5000);
}

TEST(LiveState, OptionsAreValidated) {
  auto bad = [](auto change) {
    LiveOptions o;
    change(o);
    EXPECT_THROW(LiveState{o}, std::invalid_argument);
  };
  bad([](LiveOptions& o) { o.window_s = 0; });
  bad([](LiveOptions& o) { o.window_s = std::nan(""); });
  bad([](LiveOptions& o) { o.series_rate_hz = -1; });
  bad([](LiveOptions& o) { o.max_events = 0; });
  bad([](LiveOptions& o) { o.new_record_after_s = 0; });
}

// Oracle: the messages fed. RL_BAND_<name> becomes "bands": its quantiles
// in degrees (180/pi per rad) at the sample times, decimated like every
// series (100 Hz: one point per 10 samples of 1 kHz), the five quantile
// arrays as long as "t"; RL_COVERAGE_<name> is its "latest", exactly as
// received; an update after a cursor carries only the newer points.
TEST(LiveState, BandsCarryTheQuantilesAndTheLatestCoverage) {
  LiveState s;
  auto band = [](std::int64_t utime, double centre) {
    rocklab::model_band_t b{};
    b.utime = utime;
    b.name = "post";
    b.model = "complex";
    b.draws = 32;
    b.members = 31;
    b.theta_median = centre;
    b.theta_lo95 = centre - 0.02;
    b.theta_lo68 = centre - 0.01;
    b.theta_hi68 = centre + 0.01;
    b.theta_hi95 = centre + 0.02;
    return b;
  };
  for (int k = 0; k < 100; ++k) {
    ASSERT_TRUE(Feed(s, "RL_THETA", Theta(kT0 + 1000 * k, 0.0)));
    ASSERT_TRUE(Feed(s, "RL_BAND_post", band(kT0 + 1000 * k, 1e-3 * k)));
  }
  rocklab::band_comparison_t c{};
  c.utime = kT0 + 99'000;
  c.name = "post";
  c.window_s = 2.0;
  c.coverage95_window = 0.875;
  c.coverage95_total = 0.9375;
  c.coverage68_window = 0.5;
  c.coverage68_total = 0.625;
  c.median_error = 1e-3;
  c.width95 = 0.04;
  c.impact_timing_z = -0.75;
  c.impact_time_sd = 0.0125;
  c.impact_timing_z_rms = 1.25;
  c.matched_crossings = 7;
  c.unmatched_crossings = 2;
  c.valid = true;
  c.samples = 100;
  c.valid_samples = 99;
  ASSERT_TRUE(Feed(s, "RL_COVERAGE_post", c));
  const json snap = s.Snapshot();
  ASSERT_EQ(snap.at("bands").size(), 1u);
  const json& b = snap.at("bands")[0];
  EXPECT_EQ(b.at("name"), "post");
  EXPECT_EQ(b.at("model"), "complex");
  EXPECT_EQ(b.at("draws"), 32);
  EXPECT_EQ(b.at("members"), 31);
  const json& q = b.at("band");
  ASSERT_EQ(q.at("t").size(), 10u);
  for (const char* key : {"median_deg", "lo68_deg", "hi68_deg", "lo95_deg", "hi95_deg"}) {
    ASSERT_EQ(q.at(key).size(), 10u) << key;
  }
  EXPECT_DOUBLE_EQ(q.at("t")[3].get<double>(), 0.030);
  EXPECT_DOUBLE_EQ(q.at("median_deg")[3].get<double>(), 0.030 * kDeg);
  EXPECT_DOUBLE_EQ(q.at("lo95_deg")[3].get<double>(), (0.030 - 0.02) * kDeg);
  EXPECT_DOUBLE_EQ(q.at("lo68_deg")[3].get<double>(), (0.030 - 0.01) * kDeg);
  EXPECT_DOUBLE_EQ(q.at("hi68_deg")[3].get<double>(), (0.030 + 0.01) * kDeg);
  EXPECT_DOUBLE_EQ(q.at("hi95_deg")[3].get<double>(), (0.030 + 0.02) * kDeg);
  const json& l = b.at("latest");
  EXPECT_EQ(l.at("coverage95_window").get<double>(), 0.875);
  EXPECT_EQ(l.at("coverage95_total").get<double>(), 0.9375);
  EXPECT_EQ(l.at("coverage68_window").get<double>(), 0.5);
  EXPECT_EQ(l.at("coverage68_total").get<double>(), 0.625);
  EXPECT_EQ(l.at("median_error").get<double>(), 1e-3);
  EXPECT_EQ(l.at("width95").get<double>(), 0.04);
  EXPECT_EQ(l.at("impact_timing_z").get<double>(), -0.75);
  EXPECT_EQ(l.at("impact_time_sd").get<double>(), 0.0125);
  EXPECT_EQ(l.at("impact_timing_z_rms").get<double>(), 1.25);
  EXPECT_EQ(l.at("matched_crossings"), 7);
  EXPECT_EQ(l.at("unmatched_crossings"), 2);
  EXPECT_EQ(l.at("valid_samples"), 99);
  EXPECT_EQ(snap.at("units").at("median_deg"), "deg");
  EXPECT_EQ(snap.at("counters").at("seq_missing").count("RL_BAND_post"), 1u);  // the type carries seq

  const std::uint64_t cursor = snap.at("cursor").get<std::uint64_t>();
  for (int k = 100; k < 120; ++k) ASSERT_TRUE(Feed(s, "RL_BAND_post", band(kT0 + 1000 * k, 0.0)));
  const json update = s.UpdateSince(cursor);
  EXPECT_EQ(update.at("bands")[0].at("band").at("t").size(), 2u);  // samples 100 and 110
}

}  // namespace
}  // namespace rocklab::monitor
