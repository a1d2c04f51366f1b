// The DAQ node over LCM. Oracles: the raw file the node reads (every RL_RAW
// frame must equal a file row, none lost, none reordered) and the Processor
// run directly on the same frames (RL_THETA must equal it bit for bit, at any
// speed). The udpm:// test runs in a private network namespace with ttl=0 and
// skips when one cannot be made (DESIGN.md, "Networking in tests").
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iostream>
#include <thread>

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>

#include "daq/daq_node.h"

#include "common/bus.h"
#include "common/direct_bus.h"
#include "common/lcm_bus.h"
#include "daq/processor.h"
#include "daq/rig_simulator.h"
#include "daq/source.h"
#include "rocklab/block_state2_t.hpp"
#include "rocklab/block_state_t.hpp"
#include "rocklab/daq_config2_t.hpp"
#include "rocklab/event2_t.hpp"
#include "rocklab/health2_t.hpp"
#include "rocklab/raw_frame_t.hpp"
#include "rocklab/table_state_t.hpp"
#include "tests/daq/daq_test_util.h"
#include "tests/skip.h"
#include "tests/tools/udpm_netns.h"
#include "common/units.h"

namespace rocklab::daq {
namespace {

using common::kPi;

TrueMotion NodeMotion(double t) {
  TrueMotion m;
  m.theta = 0.04 * std::sin(2 * kPi * 1.5 * t);
  m.table_displacement = 0.006 * std::sin(2 * kPi * 5 * t);
  m.table_acceleration = -0.006 * std::pow(2 * kPi * 5, 2) * std::sin(2 * kPi * 5 * t);
  return m;
}

// A raw CSV of `duration_s` through the simulator (typical noise, seeded).
std::string MakeRawCsv(const RigConfig& rig, const std::string& name, double duration_s) {
  const std::string path = test::ScratchDir() + "/" + name;
  RigSimulator sim(rig, SimulatorNoise::Typical(), 17);
  RawFileWriter out(path, RawFileWriter::Format::kCsv, sim.channel_names(), rig.sample_rate_hz);
  std::vector<double> raw;
  for (int k = 0; k <= duration_s * rig.sample_rate_hz; ++k) {
    const double t = k / rig.sample_rate_hz;
    if (sim.Raw(NodeMotion(t), raw)) out.Write(t, raw);
  }
  out.Close();
  return path;
}

std::vector<Frame> ReadFrames(const std::string& path, const RigConfig& rig) {
  SourceOptions opt;
  opt.sample_rate_hz = rig.sample_rate_hz;
  auto source = OpenSource(path, opt);
  std::vector<Frame> frames;
  Frame f;
  while (source->Next(f) == ReadStatus::kFrame) frames.push_back(f);
  return frames;
}

bool SameValue(double a, double b) { return a == b || (std::isnan(a) && std::isnan(b)); }

struct Collector {
  std::vector<std::string> order;  // channel of every message, in arrival order
  std::vector<rocklab::raw_frame_t> raw;
  std::vector<rocklab::block_state_t> theta;
  std::vector<rocklab::block_state2_t> bodies;
  std::vector<rocklab::table_state_t> table;
  std::vector<rocklab::event2_t> events;
  std::vector<rocklab::health2_t> health;
  std::vector<rocklab::daq_config2_t> config;
  std::vector<common::Subscription> subscriptions;  // end with the collector (or its bus)
  template <class Msg>
  void Add(common::Bus& bus, const char* channel, std::vector<Msg>& into) {
    subscriptions.push_back(bus.Subscribe<Msg>(channel, [this, &into](const std::string& c, const Msg& m) {
      order.push_back(c);
      into.push_back(m);
    }));
  }
  void Subscribe(common::Bus& bus) {
    Add(bus, "RL_RAW", raw);
    Add(bus, "RL_THETA", theta);
    Add(bus, "RL_BODIES", bodies);
    Add(bus, "RL_TABLE", table);
    Add(bus, "RL_EVENT", events);
    Add(bus, "RL_HEALTH", health);
    Add(bus, "RL_DAQ_CONFIG", config);
  }
};

DaqNodeConfig ConfigFor(const RigConfig& rig, const std::string& input, double speed) {
  DaqNodeConfig config;
  config.rig = rig;
  config.input = input;
  config.speed = speed;
  return config;
}

// Runs the node on memq:// and collects everything it published.
std::unique_ptr<Collector> RunOnMemq(const RigConfig& rig, const std::string& input, double speed,
                                     std::atomic<bool>& stop, DaqNodeStats* stats = nullptr) {
  common::LcmBus lcm("memq://");
  auto c = std::make_unique<Collector>();
  c->Subscribe(lcm);
  DaqNode node(ConfigFor(rig, input, speed), lcm);
  node.Run(stop);
  while (lcm.HandleTimeout(0) > 0) {
  }
  if (stats != nullptr) *stats = node.stats();
  return c;
}

// Runs the node on a DirectBus (handlers called as it publishes) and sets
// `stop` when its `stop_at_raw`-th RL_RAW is published: a stop in the middle
// of the input on a condition, never after a fixed sleep.
std::unique_ptr<Collector> RunOnDirectBusUntil(const RigConfig& rig, const std::string& input,
                                               double speed, std::int64_t stop_at_raw,
                                               std::atomic<bool>& stop, DaqNodeStats* stats) {
  common::DirectBus bus;
  auto c = std::make_unique<Collector>();
  c->Subscribe(bus);
  std::int64_t raw = 0;
  const common::Subscription counter = bus.SubscribeRaw("RL_RAW", [&raw, &stop, stop_at_raw](const std::string&, const void*, int) {
    if (++raw >= stop_at_raw) stop = true;
  });
  DaqNode node(ConfigFor(rig, input, speed), bus);
  node.Run(stop);
  *stats = node.stats();
  return c;
}

TEST(DaqNode, MemqRoundTripPublishesEveryFrameAndTheSameReconstruction) {
  const RigConfig rig = LoadRigConfig(test::LabRigPath());
  const std::string input = MakeRawCsv(rig, "node.csv", 1.0);
  const auto frames = ReadFrames(input, rig);
  std::atomic<bool> stop{false};
  DaqNodeStats stats;
  const auto c = RunOnMemq(rig, input, 0, stop, &stats);

  ASSERT_EQ(c->raw.size(), frames.size());
  for (size_t i = 0; i < frames.size(); ++i) {
    ASSERT_EQ(c->raw[i].seq, frames[i].seq);
    ASSERT_EQ(c->raw[i].utime, frames[i].utime());
    ASSERT_EQ(c->raw[i].values.size(), frames[i].values.size());
    for (size_t k = 0; k < frames[i].values.size(); ++k) {
      ASSERT_TRUE(SameValue(c->raw[i].values[k], frames[i].values[k])) << i << " " << k;
    }
  }
  // A single block's rig: RL_THETA only, no RL_BODIES.
  EXPECT_FALSE(c->theta.empty());
  EXPECT_TRUE(c->bodies.empty());
  // The description comes before the first frame.
  ASSERT_FALSE(c->config.empty());
  EXPECT_LT(std::find(c->order.begin(), c->order.end(), "RL_DAQ_CONFIG") - c->order.begin(),
            std::find(c->order.begin(), c->order.end(), "RL_RAW") - c->order.begin());
  EXPECT_EQ(c->config[0].channel_names, RigSimulator(rig, {}, 0).channel_names());
  EXPECT_EQ(c->config[0].channel_sensors[0], "mirror.s");

  // RL_THETA and RL_TABLE equal a direct Processor run on the same frames.
  test::CollectSink direct;
  Processor proc(rig, RigSimulator(rig, {}, 0).channel_names(), input, direct);
  for (const Frame& f : frames) proc.Process(f);
  proc.Finish();
  ASSERT_EQ(c->theta.size(), direct.block.size());
  for (size_t i = 0; i < direct.block.size(); ++i) {
    EXPECT_EQ(c->theta[i].utime, direct.block[i].utime);
    EXPECT_TRUE(SameValue(c->theta[i].theta, direct.block[i].theta));
    EXPECT_TRUE(SameValue(c->theta[i].theta_dot, direct.block[i].theta_dot));
    EXPECT_EQ(c->theta[i].flags, direct.block[i].flags);
  }
  EXPECT_EQ(c->table.size(), direct.table.size());
  // Simulated drops: GAP events, counted in the last health message.
  ASSERT_FALSE(c->health.empty());
  const auto& last = c->health.back();
  EXPECT_EQ(last.state, "stopped");
  EXPECT_EQ(last.count_in, static_cast<int64_t>(frames.size()));
  EXPECT_EQ(last.gaps, proc.sequence().gaps);
  EXPECT_EQ(last.dropped, proc.sequence().missing);
  int gap_events = 0;
  for (const auto& e : c->events) gap_events += e.kind == rocklab::event2_t::GAP;
  EXPECT_EQ(gap_events, proc.sequence().gaps);
  EXPECT_EQ(stats.publish_errors, 0);
  EXPECT_FALSE(stats.stopped_early);
}

// The RL_THETA and RL_TABLE of a sample go out together, RL_THETA
// first, so no subscriber has to hold either back. Oracle: every RL_TABLE
// is the message right after an RL_THETA of the same seq (the simulated
// drops included: a dropped sample has neither).
TEST(DaqNode, ThetaAndTableOfASampleArePublishedTogether) {
  const RigConfig rig = LoadRigConfig(test::LabRigPath());
  const std::string input = MakeRawCsv(rig, "pairs.csv", 1.0);
  std::atomic<bool> stop{false};
  const auto c = RunOnMemq(rig, input, 0, stop);
  ASSERT_FALSE(c->table.empty());
  ASSERT_EQ(c->theta.size(), c->table.size());
  std::size_t theta_i = 0, table_i = 0;
  for (std::size_t i = 0; i < c->order.size(); ++i) {
    if (c->order[i] == "RL_THETA") ++theta_i;
    if (c->order[i] != "RL_TABLE") continue;
    ASSERT_GT(i, 0u);
    ASSERT_EQ(c->order[i - 1], "RL_THETA") << "message " << i;
    ASSERT_EQ(c->table[table_i].seq, c->theta[theta_i - 1].seq) << "table " << table_i;
    ASSERT_EQ(c->table[table_i].utime, c->theta[theta_i - 1].utime) << "table " << table_i;
    ++table_i;
  }
  EXPECT_EQ(table_i, c->table.size());
}

// A rig of two bodies (data/rigs/statue_rig.toml): RL_BODIES
// (block_state2_t) right after every RL_THETA, of the same sample, nbodies
// 2, its body 0 the RL_THETA's values bit for bit (one reconstruction,
// copied by the field table); the statue's angle its own (oracle: the
// motion given to the simulator, within 6 sigma of its mirror, 1.25e-5 rad
// at half the typical noise, sigma_s / (2 D)); its 3 mm slide on the
// pedestal from 0.3 s measured within 5 sigma of the relative pivot (1.1e-4
// m: two fits, docs/acquisition.md), flagged, and one RL_EVENT naming it.
TEST(DaqNode, MultiBodyRigPublishesEveryBodyBesideTheBottomOnesTheta) {
  const RigConfig rig = LoadRigConfig(std::string(ROCKLAB_SOURCE_DIR) + "/data/rigs/statue_rig.toml");
  const std::string path = test::ScratchDir() + "/bodies.csv";
  SimulatorNoise noise = SimulatorNoise::Typical().Scaled(0.5);
  noise.occlusion = noise.drop = 0;
  RigSimulator sim(rig, noise, 5);
  RawFileWriter out(path, RawFileWriter::Format::kCsv, sim.channel_names(), rig.sample_rate_hz);
  std::vector<double> raw;
  auto statue = [](double t) { return 0.03 * std::sin(2 * kPi * 1.5 * t); };
  for (int k = 0; k <= 500; ++k) {
    const double t = k / rig.sample_rate_hz;
    TrueMotion m = NodeMotion(t);
    m.body_theta[0] = 0.2 * m.theta;
    m.body_theta[1] = statue(t);
    m.slip_body = 1;
    m.slip_m = t >= 0.3 ? 0.003 : 0.0;  // the statue slides 3 mm on the pedestal
    if (sim.Raw(m, raw)) out.Write(t, raw);
  }
  out.Close();
  std::atomic<bool> stop{false};
  const auto c = RunOnMemq(rig, path, 0, stop);
  ASSERT_GT(c->theta.size(), 400u);
  ASSERT_EQ(c->bodies.size(), c->theta.size());
  std::size_t theta_i = 0, bodies_i = 0;
  for (std::size_t i = 0; i < c->order.size(); ++i) {
    if (c->order[i] == "RL_THETA") ++theta_i;
    if (c->order[i] != "RL_BODIES") continue;
    ASSERT_EQ(c->order[i - 1], "RL_THETA") << "message " << i;
    const rocklab::block_state_t& one = c->theta[theta_i - 1];
    const rocklab::block_state2_t& all = c->bodies[bodies_i++];
    ASSERT_EQ(all.seq, one.seq);
    ASSERT_EQ(all.utime, one.utime);
    ASSERT_EQ(all.nbodies, 2);
    ASSERT_EQ(all.theta.size(), 2u);
    ASSERT_TRUE(SameValue(all.theta[0], one.theta));
    ASSERT_TRUE(SameValue(all.theta_dot[0], one.theta_dot));
    ASSERT_TRUE(SameValue(all.sliding[0], one.sliding));
    ASSERT_EQ(all.flags[0], one.flags);
    ASSERT_EQ(all.leds_used[0], 4);
    ASSERT_EQ(all.leds_used[1], 4);
    ASSERT_TRUE(std::isnan(all.theta_mirror[0]));  // the mirror is the statue's
    ASSERT_NEAR(all.theta[1], statue(static_cast<double>(all.utime) * 1e-6), 6 * 0.5e-4 / (2 * 2.0)) << i;
    ASSERT_TRUE(std::isfinite(all.sliding[1])) << "the statue's relative slide is measured";
    ASSERT_NEAR(all.sliding[1], all.utime >= 300000 ? 0.003 : 0.0, 5 * 1.1e-4) << i;
    ASSERT_EQ(all.flags[1] & rocklab::block_state2_t::FLAG_SLIDING, all.utime >= 300000 ? 1 : 0) << i;
  }
  // One event, at the slide's first sample, naming the body and interface.
  int slides = 0;
  for (const auto& e : c->events) {
    if (e.kind != rocklab::event2_t::SLIDING) continue;
    ++slides;
    EXPECT_EQ(e.utime, 300000);
    EXPECT_EQ(e.detail, "body statue (interface 2): sliding above tolerance");
  }
  EXPECT_EQ(slides, 1);
}

// Oracle: the first frame's sample clock. RL_HEALTH "starting" carries it
// (not 0), so a log of the run does not begin decades before its data when
// the clock is an epoch's (here 1.7e9 s).
TEST(DaqNode, StartingHealthCarriesTheFirstFramesSampleClock) {
  const RigConfig rig = LoadRigConfig(test::LabRigPath());
  std::ifstream in(MakeRawCsv(rig, "epoch_src.csv", 0.2));
  std::string text, line;
  for (bool header = true; std::getline(in, line); header = false) {
    if (!header) {
      const std::size_t comma = line.find(',');
      char t[64];
      std::snprintf(t, sizeof t, "%.6f", 1.7e9 + std::stod(line.substr(0, comma)));
      line = t + line.substr(comma);
    }
    text += line + "\n";
  }
  const std::string input = test::WriteFile("epoch.csv", text);
  std::atomic<bool> stop{false};
  const auto c = RunOnMemq(rig, input, 0, stop);
  ASSERT_FALSE(c->raw.empty());
  ASSERT_FALSE(c->health.empty());
  EXPECT_EQ(c->health.front().state, "starting");
  EXPECT_EQ(c->health.front().utime, c->raw.front().utime);
  EXPECT_GT(c->raw.front().utime, 1'600'000'000'000'000);
}

TEST(DaqNode, StopFlagEndsTheRunAndPublishesWhatWasRead) {
  const RigConfig rig = LoadRigConfig(test::LabRigPath());
  const std::string input = MakeRawCsv(rig, "stop.csv", 5.0);
  std::atomic<bool> stop{false};
  DaqNodeStats stats;
  // Real time: 5 s of data, stopped at its 300th frame (0.3 s of the sample
  // clock). The node checks the stop between frames: it reads no frame after it.
  const auto c = RunOnDirectBusUntil(rig, input, 1.0, 300, stop, &stats);
  EXPECT_TRUE(stats.stopped_early);
  EXPECT_EQ(stats.frames_read, 300);
  EXPECT_EQ(static_cast<int64_t>(c->raw.size()), stats.frames_read);
  // Every frame read is reconstructed, the delayed tail flushed.
  EXPECT_EQ(static_cast<int64_t>(c->theta.size()), stats.frames_read);
  EXPECT_EQ(c->health.back().state, "stopped");
}

TEST(DaqNode, SpeedFactorPacesOnTheSampleClock) {
  const RigConfig rig = LoadRigConfig(test::LabRigPath());
  const std::string input = MakeRawCsv(rig, "pace.csv", 1.0);
  const auto frames = ReadFrames(input, rig);
  std::atomic<bool> stop{false};
  const auto start = std::chrono::steady_clock::now();
  RunOnMemq(rig, input, 4.0, stop);
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  // A lower bound only (no timing upper bounds in tests): at 4x the last
  // frame is not published before (t_last - t_first) / 4 host seconds.
  EXPECT_GE(elapsed, (frames.back().time_s - frames.front().time_s) / 4.0);
}

// In a child process: a private network namespace with multicast on lo,
// rocklab record recording udpm://...?ttl=0 while the node publishes, then the
// log decoded back. Exit 77 = no namespace (skip), 0 = pass.
int UdpmChild(const RigConfig& rig, const std::string& input, const std::string& log_path) {
  const std::string why = rocklab::test::EnterPrivateNetwork();
  if (!why.empty()) {
    std::cerr << why << "\n";
    return 77;
  }
  const pid_t logger = rocklab::test::StartRecorder(log_path);
  if (logger < 0) {
    std::cerr << "rocklab record did not start\n";
    return 1;
  }
  DaqNodeConfig config;
  config.rig = rig;
  config.input = input;
  config.speed = 1.0;
  {
    common::LcmBus bus(rocklab::test::kUdpmUrl);
    DaqNode node(config, bus);
    std::atomic<bool> stop{false};
    node.Run(stop);
    if (node.stats().publish_errors != 0) {
      std::cerr << node.stats().publish_errors << " publish errors\n";
      return 1;
    }
  }
  if (rocklab::test::StopRecorder(logger, log_path) != 0) {
    std::cerr << "rocklab record did not exit cleanly\n";
    return 1;
  }
  const auto want = ReadFrames(input, rig);
  const auto got = ReadFrames(log_path, rig);
  if (got.size() != want.size()) {
    std::cerr << "log has " << got.size() << " frames, the file " << want.size() << "; first seqs:";
    for (size_t i = 0; i < 3 && i < got.size(); ++i) std::cerr << " " << got[i].seq;
    std::cerr << "; last: " << (got.empty() ? -1 : got.back().seq) << "; missing:";
    for (size_t i = 0, j = 0; i < want.size(); ++i) {
      if (j < got.size() && got[j].seq == want[i].seq) {
        ++j;
      } else {
        std::cerr << " " << want[i].seq;
      }
    }
    std::cerr << "\n";
    return 1;
  }
  for (size_t i = 0; i < want.size(); ++i) {
    bool same = got[i].seq == want[i].seq && got[i].utime() == want[i].utime() &&
                got[i].values.size() == want[i].values.size();
    for (size_t k = 0; same && k < want[i].values.size(); ++k) {
      same = SameValue(got[i].values[k], want[i].values[k]);
    }
    if (!same) {
      std::cerr << "frame " << i << " differs\n";
      return 1;
    }
  }
  return 0;
}

TEST(DaqNode, UdpmInAPrivateNamespaceRecordedDecodesToTheSameFrames) {
  const RigConfig rig = LoadRigConfig(test::LabRigPath());
  const std::string input = MakeRawCsv(rig, "udpm.csv", 0.5);
  const std::string log_path = test::ScratchDir() + "/udpm.lcmlog";
  std::cout.flush();
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) _exit(UdpmChild(rig, input, log_path));
  int status = 0;
  waitpid(child, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  if (WEXITSTATUS(status) == 77) ROCKLAB_SKIP("no private network namespace (needs root): udpm test skipped");
  EXPECT_EQ(WEXITSTATUS(status), 0) << "see the child's messages above";
}

}  // namespace
}  // namespace rocklab::daq

namespace rocklab::daq {
namespace {

// A malformed row and a text value: both reach RL_EVENT as BAD_SAMPLE with
// file and line, the health counts them, and every other frame is published.
TEST(DaqNode, SourceProblemsArePublishedAsEventsWithFileAndLine) {
  const RigConfig rig = LoadRigConfig(test::LabRigPath());
  const std::string good = MakeRawCsv(rig, "good.csv", 0.2);
  std::ifstream in(good);
  std::string text, line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (n == 10) line = line.substr(0, line.rfind(','));        // ragged: one field short
    if (n == 20) line.replace(line.find(',') + 1, 1, "x");      // text in mirror_s
    text += line + "\n";
  }
  const std::string bad = test::WriteFile("bad_node.csv", text);
  std::atomic<bool> stop{false};
  const auto c = RunOnMemq(rig, bad, 0, stop);
  std::vector<std::string> details;
  for (const auto& e : c->events) {
    if (e.kind == rocklab::event2_t::BAD_SAMPLE) details.push_back(e.detail);
  }
  ASSERT_EQ(details.size(), 2u);
  EXPECT_EQ(details[0].rfind(bad + ":10: row has 14 fields, the header has 15", 0), 0u) << details[0];
  EXPECT_EQ(details[1].rfind(bad + ":20: column 'mirror_s': '", 0), 0u) << details[1];
  EXPECT_EQ(c->health.back().bad_samples, 2);
  EXPECT_EQ(c->raw.size(), ReadFrames(good, rig).size() - 1);  // only the ragged row is missing
}

// daq/source.h's contract ("Next() never throws"). An input
// none of whose rows can be used ends the read with ReadStatus::kError: Run
// does not throw, the node still shuts down in order (RL_HEALTH "stopping"
// then "stopped"), and the stats name the file for the command's exit.
// Oracle: the file's rows (every one ragged).
TEST(DaqNode, ReadErrorEndsTheRunInOrderNamingTheFile) {
  const RigConfig rig = LoadRigConfig(test::LabRigPath());
  const std::string good = MakeRawCsv(rig, "allbad_src.csv", 0.05);
  std::ifstream in(good);
  std::string text, line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (n > 1) line = line.substr(0, line.rfind(','));  // every data row one field short
    text += line + "\n";
  }
  const std::string bad = test::WriteFile("allbad_node.csv", text);
  std::atomic<bool> stop{false};
  DaqNodeStats stats;
  const auto c = RunOnMemq(rig, bad, 0, stop, &stats);
  EXPECT_EQ(stats.frames_read, 0);
  EXPECT_NE(stats.read_error.find(bad + ": none of the"), std::string::npos) << stats.read_error;
  ASSERT_GE(c->health.size(), 2u);
  EXPECT_EQ(c->health[c->health.size() - 2].state, "stopping");
  EXPECT_EQ(c->health.back().state, "stopped");
}

}  // namespace
}  // namespace rocklab::daq
