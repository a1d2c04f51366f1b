// `rocklab run`: daq, model and compare in one process, through the binary.
// Oracles: the parameters the bundled synthetic test was generated with
// (data/samples/README.md), the payloads of the same run at another speed,
// and the node shutdown order written in pipeline/run_graph.h (RunGraph::Run).
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>
#include <nlohmann/json.hpp>

#include "rocklab/block_state_t.hpp"
#include "rocklab/health2_t.hpp"
#include "tests/tools/log_count.h"
#include "tests/tools/run_cli.h"
#include "tests/source_paths.h"

namespace rocklab::pipeline {
namespace {

using ::rocklab::test::kSource;  // tests/source_paths.h
const std::string kBlock1Rig = kSource + "/data/rigs/block1_rig.toml";
const std::string kFig7 = kSource + "/data/samples/fig7_block1.csv";
using ::rocklab::test::kLabRig;  // tests/source_paths.h
const std::string kFreeRocking = kSource + "/data/samples/free_rocking.csv";

std::map<std::string, nlohmann::json> SummaryByName(const std::string& path) {
  std::map<std::string, nlohmann::json> out;
  const nlohmann::json doc = nlohmann::json::parse(test::ReadFile(path));
  for (const auto& v : doc.at("variants")) {
    out[v.at("name").get<std::string>()] = v;
  }
  return out;
}

// A forced synthetic test of block 1 (complex model, alpha 0.235, p 3.884,
// mu 0.937, lab noise, seed 8) under a Hanning 10 mm, 3.3 Hz table motion
// (peak 4.3 m/s^2, well above the uplift threshold g tan(alpha) = 2.35 m/s^2)
// through the whole pipeline over memq.
// Oracle: with the parameters it was made with, the model follows the
// measurement up to (a) the DAQ's theta error, nrms 7e-4 measured with
// `rocklab reconstruct` against the truth file (the mirror's 2.5e-5 rad
// against a 0.044 rad peak), and (b) the model's timing sensitivity to the
// noisy table acceleration (accelerometer noise shifts uplift and every
// impact): measured nrms 0.0097 (seed 8) and 0.0110 (seed 7) with a mean
// |impact timing error| of 2.7 ms. Bound 0.025: 2.5x the measured value,
// i.e. impact timing errors up to ~6 ms. mu off by 0.03 (0.907) loses 3 % of
// the rocking speed at each of ~90 impacts: measured 0.070, asserted above
// 2x the bound. The bundled figure-7 demo (6 mm) is NOT used for this bound:
// its peak acceleration is only 10 % above the uplift threshold, and the
// first small rocking cycles then depend on the noise (docs/commands.md: `rocklab run`).
TEST(RocklabRun, TrueParametersTrackTheMeasurementAndWrongMuDoesNot) {
  const std::string dir = test::ScratchDir("run_nrms");
  const std::string raw = dir + "/forced.csv";
  const test::CliResult synth = test::RunCli(
      {"synth", "--rig", kBlock1Rig, "--model", "complex", "--alpha", "0.235", "--p", "3.884",
       "--mu", "0.937", "--excitation", "hanning:amp=0.010,freq=3.3,duration=4,start=0.5",
       "--duration", "7", "--rate", "1000", "--seed", "8", "--out", raw, "--truth",
       dir + "/forced.truth.csv"});
  ASSERT_EQ(synth.exit_code, 0) << synth.err;
  const std::string summary = dir + "/summary.json";
  const test::CliResult r = test::RunCli(
      {"run", "--rig", kBlock1Rig, "--input", raw, "--max",
       "--variant", "true_c:complex:alpha=0.235,p=3.884,mu=0.937",
       "--variant", "mu_off:complex:alpha=0.235,p=3.884,mu=0.907",
       "--summary", summary});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("true_c"), std::string::npos) << r.out;  // the summary table
  const auto s = SummaryByName(summary);
  ASSERT_EQ(s.size(), 2u);
  constexpr double kBound = 0.025;
  EXPECT_LT(s.at("true_c").at("nrms").get<double>(), kBound);
  EXPECT_GT(s.at("true_c").at("samples").get<int>(), 6900);  // every sample paired
  EXPECT_GT(s.at("mu_off").at("nrms").get<double>(), 2 * kBound);
}

// The bundled demo runs end to end: every measured sample is paired with
// every variant. Oracle: the file's 6996 rows (7 s at 1 kHz, 5 dropped).
// The bench's 600 s record (bench/figures.py's synth) cut to 181 s: at
// 179.564 s the block micro-rocks (theta ~ 1e-7 rad, theta_dot ~ 2e-4
// rad/s, the table just above g tan(alpha)) and the complex model with
// Table 1's parameters crosses the origin there. The node's Dormand-Prince
// 5(4) needs steps of a few 1e-13 s for that crossing; with its smallest
// step at 16 ulp of t (6.4e-13 s there) it gave up and the variant stopped
// for the rest of the run (docs/models.md). Oracle: the node's own count,
// "0 model failures", and every sample modelled.
TEST(RocklabRun, TheComplexNodeCrossesTheOriginAtMicroRocking) {
  const std::string dir = test::ScratchDir("run_micro");
  const std::string raw = dir + "/r181.csv";
  const test::CliResult synth = test::RunCli(
      {"synth", "--rig", kBlock1Rig, "--model", "complex", "--alpha", "0.235", "--p", "3.884", "--mu", "0.937",
       "--excitation", "sine:amp=0.010,freq=3.3,duration=180,start=0.5", "--duration", "181", "--rate", "1000",
       "--seed", "1", "--out", raw, "--truth", dir + "/r181.truth.csv"});
  ASSERT_EQ(synth.exit_code, 0) << synth.err;
  const test::CliResult r =
      test::RunCli({"run", "--rig", kBlock1Rig, "--input", raw, "--max", "--quiet", "--variant",
                    "theory_complex:complex:theoretical"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find(", 0 model failures,"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("stopped at utime"), std::string::npos) << r.err;
}

TEST(RocklabRun, BundledDemoPairsEverySample) {
  const std::string summary = test::ScratchDir("run_demo") + "/summary.json";
  const test::CliResult r = test::RunCli(
      {"run", "--rig", kBlock1Rig, "--input", kFig7, "--max", "--variant",
       "fitted:complex:alpha=0.235,p=3.884,mu=0.937", "--variant", "theory:housner:theoretical",
       "--summary", summary});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto s = SummaryByName(summary);
  ASSERT_EQ(s.size(), 2u);
  for (const auto& [name, v] : s) {
    EXPECT_EQ(v.at("samples").get<int>(), 6996) << name;
    EXPECT_EQ(v.at("unmatched_model").get<int>(), 0) << name;
  }
}

// LCM log -> (channel, payload) of the channels the determinism law covers.
std::vector<std::pair<std::string, std::string>> ModelAndComparePayloads(const std::string& path) {
  lcm::LogFile log(path, "r");
  EXPECT_TRUE(log.good()) << path;
  std::vector<std::pair<std::string, std::string>> out;
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    if (ev->channel.rfind("RL_MODEL_", 0) == 0 || ev->channel.rfind("RL_COMPARE_", 0) == 0) {
      out.emplace_back(ev->channel,
                       std::string(static_cast<const char*>(ev->data), ev->datalen));
    }
  }
  return out;
}

// The same input gives byte-identical RL_MODEL_* and
// RL_COMPARE_* payloads at --max, --speed 10 and --speed 1. Oracle: the
// --max run; exact equality (every message is stamped with the sample clock,
// and the stages are connected by direct calls in one thread, so the host
// clock must not reach any of these payloads). Input: the 1 s free-rocking
// sample, so the paced run takes about 1 s.
TEST(RocklabRun, ModelAndComparePayloadsAreTheSameAtEverySpeed) {
  const std::string dir = test::ScratchDir("run_speeds");
  std::vector<std::vector<std::pair<std::string, std::string>>> runs;
  for (const std::vector<std::string>& speed :
       {std::vector<std::string>{"--max"}, {"--speed", "10"}, {"--speed", "1"}}) {
    const std::string log = dir + "/run" + std::to_string(runs.size()) + ".lcm";
    std::vector<std::string> args = {"run", "--rig", kLabRig, "--input", kFreeRocking,
                                     "--log", log};
    args.insert(args.end(), speed.begin(), speed.end());
    const test::CliResult r = test::RunCli(args);
    ASSERT_EQ(r.exit_code, 0) << speed[0] << ": " << r.err;
    runs.push_back(ModelAndComparePayloads(log));
  }
  ASSERT_GT(runs[0].size(), 1500u);  // two variants x ~1 s at 1 kHz, plus RL_COMPARE_*
  int compares = 0;
  for (const auto& [channel, payload] : runs[0]) compares += channel.rfind("RL_COMPARE_", 0) == 0;
  EXPECT_GT(compares, 20);  // 20 Hz x 2 variants x ~1 s
  for (std::size_t i = 1; i < runs.size(); ++i) {
    ASSERT_EQ(runs[i].size(), runs[0].size()) << "run " << i;
    for (std::size_t k = 0; k < runs[0].size(); ++k) {
      ASSERT_EQ(runs[i][k].first, runs[0][k].first) << "run " << i << " message " << k;
      ASSERT_EQ(runs[i][k].second, runs[0][k].second)
          << "run " << i << " message " << k << " on " << runs[0][k].first;
    }
  }
}

// The demo's log has stamps that never go back (the newest
// sample-clock utime so far), every payload keeps its own utime, and
// `rocklab replay` publishes every event of it. Oracle: the events counted
// in the file by liblcm's own reader.
TEST(RocklabRun, LogStampsNeverGoBackAndReplayPublishesEveryEvent) {
  const std::string dir = test::ScratchDir("run_log_order");
  const std::string log = dir + "/demo.lcm";
  const test::CliResult r =
      test::RunCli({"run", "--rig", kBlock1Rig, "--input", kFig7, "--max", "--log", log});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  lcm::LogFile in(log, "r");
  ASSERT_TRUE(in.good());
  std::int64_t events = 0, back = 0, previous = INT64_MIN, utime_behind_stamp = 0;
  while (const lcm::LogEvent* ev = in.readNextEvent()) {
    ++events;
    back += ev->timestamp < previous;
    previous = ev->timestamp;
    if (ev->channel == "RL_THETA") {
      rocklab::block_state_t m;
      ASSERT_GE(m.decode(ev->data, 0, ev->datalen), 0);
      EXPECT_LE(m.utime, ev->timestamp);
      utime_behind_stamp += m.utime < ev->timestamp;
    }
  }
  EXPECT_GT(events, 30000);  // 7 s at 1 kHz: RL_RAW, RL_THETA, RL_TABLE, two RL_MODEL_*, ...
  EXPECT_EQ(back, 0);
  const test::CliResult replay = test::RunCli({"replay", log, "--max", "--lcm-url", "memq://"});
  ASSERT_EQ(replay.exit_code, 0) << replay.err;
  EXPECT_NE(replay.err.find("replayed " + std::to_string(events) + " events (" +
                            std::to_string(events) + " read"),
            std::string::npos)
      << replay.err;
}

// SIGTERM to a paced run: exit 0 after the shutdown order of RunGraph::Run.
// Oracle: in the --log, the last RL_HEALTH of each node (daq, model,
// compare) says "stopped", the daq's comes before the model's and the
// comparator's, the run stopped early (fewer frames than the 7 s input),
// and the summary table is still printed.
TEST(RocklabRun, SigtermExitsZeroAfterFinalHealth) {
  const std::string dir = test::ScratchDir("run_sigterm");
  const std::string log = dir + "/run.lcm";
  const std::string out = dir + "/stdout";
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const std::string binary = ROCKLAB_BINARY;
    if (!freopen(out.c_str(), "w", stdout) || !freopen("/dev/null", "w", stderr)) _exit(126);
    execl(binary.c_str(), binary.c_str(), "run", "--rig", kBlock1Rig.c_str(), "--input",
          kFig7.c_str(), "--speed", "1", "--log", log.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  // SIGTERM once the log holds 600 frames (0.6 s of the sample clock; the
  // --log is written as the run goes), not after a fixed sleep: on a loaded
  // machine the run may take seconds to start. The 7 s input leaves 6 s of
  // margin before the run would end by itself.
  EXPECT_TRUE(test::WaitUntil([&] { return test::CountLogEvents(log, "RL_RAW") >= 600; }))
      << "the run did not log 600 frames within 60 s";
  ASSERT_EQ(kill(pid, SIGTERM), 0);
  int status = 0;
  ASSERT_EQ(waitpid(pid, &status, 0), pid);
  ASSERT_TRUE(WIFEXITED(status)) << "killed by signal " << WTERMSIG(status);
  EXPECT_EQ(WEXITSTATUS(status), 0);

  lcm::LogFile in(log, "r");
  ASSERT_TRUE(in.good());
  std::map<std::string, rocklab::health2_t> last;
  std::map<std::string, int64_t> last_index;
  int64_t index = 0, raw = 0;
  while (const lcm::LogEvent* ev = in.readNextEvent()) {
    ++index;
    if (ev->channel == "RL_RAW") ++raw;
    if (ev->channel != "RL_HEALTH") continue;
    rocklab::health2_t h;
    ASSERT_GE(h.decode(ev->data, 0, ev->datalen), 0);
    last[h.node] = h;
    last_index[h.node] = index;
  }
  for (const char* node : {"daq", "model", "compare"}) {
    ASSERT_EQ(last.count(node), 1u) << node;
    EXPECT_EQ(last[node].state, "stopped") << node;
  }
  EXPECT_LT(last_index["daq"], last_index["model"]);
  EXPECT_LT(last_index["model"], last_index["compare"]);
  EXPECT_GE(raw, 600);   // ran at least until the wait saw 600 frames ...
  EXPECT_LT(raw, 6000);  // ... of the 7 s input
  EXPECT_EQ(last["daq"].count_in, raw);  // every frame read was published
  EXPECT_NE(test::ReadFile(out).find("housner"), std::string::npos);  // summary printed
}

// Start-up errors are usage errors (exit 2) on one line naming the option.
// Oracle: the CLI's error convention (tools/cli.h).
TEST(RocklabRun, StartUpErrorsNameTheOption) {
  test::CliResult r = test::RunCli({"run", "--rig", kLabRig, "--input", "/nonexistent.csv", "--max"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err, "rocklab: --input: /nonexistent.csv: cannot open the input file\n");
  r = test::RunCli({"run", "--rig", kLabRig, "--input", kFreeRocking, "--speed", "-1"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err, "rocklab: --speed must be >= 0, got -1\n");
  r = test::RunCli({"run", "--rig", kLabRig, "--input", kFreeRocking, "--max", "--log",
                    "/nonexistent/x.lcm"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(r.err, "rocklab: --log: cannot write '/nonexistent/x.lcm'\n");
}

// `--log /dev/full`. Every event that cannot be written
// is counted and reported at exit, with exit 1. Oracle: the events of the
// same run written to a real file. The two runs publish the same messages
// except RL_HEALTH, whose periodic messages follow the host clock: the lost
// count equals the file's events up to the number of RL_HEALTH in it (+2).
// (LcmLog.WriterOnAFullDiskCountsEveryLostEvent holds the exact count.)
TEST(RocklabRun, LogOnAFullDiskCountsEveryLostEventAndFails) {
  const std::string dir = test::ScratchDir("run_log_full");
  const std::string log = dir + "/ok.lcm";
  const test::CliResult ok =
      test::RunCli({"run", "--rig", kBlock1Rig, "--input", kFig7, "--max", "--log", log});
  ASSERT_EQ(ok.exit_code, 0) << ok.err;
  lcm::LogFile in(log, "r");
  ASSERT_TRUE(in.good());
  std::int64_t events = 0, health = 0;
  while (const lcm::LogEvent* ev = in.readNextEvent()) {
    ++events;
    health += ev->channel == "RL_HEALTH";
  }
  const test::CliResult full =
      test::RunCli({"run", "--rig", kBlock1Rig, "--input", kFig7, "--max", "--log", "/dev/full"});
  EXPECT_EQ(full.exit_code, 1) << full.err;
  const std::string says = "run: --log /dev/full: ";
  const std::size_t at = full.err.find(says);
  ASSERT_NE(at, std::string::npos) << full.err;
  const long long lost = std::stoll(full.err.substr(at + says.size()));
  EXPECT_NE(full.err.find("events could not be written and are lost (No space left on device); 0 written"),
            std::string::npos)
      << full.err;
  EXPECT_LE(std::llabs(lost - events), health + 2) << "lost " << lost << ", file " << events;
}

}  // namespace
}  // namespace rocklab::pipeline
