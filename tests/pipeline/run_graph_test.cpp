// pipeline::RunGraph, the one-process graph of `rocklab run`, as a library.
// Oracles: the bundled input's row count (data/samples/fig7_block1.csv), the
// log the graph's tap writes (every frame read is published, the shutdown
// order RunGraph::Run documents), and the comparator pairing every sample
// (as tests/pipeline/run_test.cpp checks through the binary).
#include "pipeline/run_graph.h"

#include <gtest/gtest.h>
#include <lcm/lcm-cpp.hpp>

#include <atomic>
#include <cstdint>
#include <fstream>
#include <map>
#include <string>

#include "pipeline/option_error.h"
#include "pipeline/pipeline.h"
#include "rocklab/health2_t.hpp"
#include "tests/scratch.h"
#include "tests/source_paths.h"

namespace rocklab::pipeline {
namespace {

using ::rocklab::test::kSource;  // tests/source_paths.h
const std::string kBlock1Rig = kSource + "/data/rigs/block1_rig.toml";
const std::string kFig7 = kSource + "/data/samples/fig7_block1.csv";

std::int64_t DataRows(const std::string& csv) {
  std::ifstream in(csv);
  std::string line;
  std::int64_t n = -1;  // the header
  while (std::getline(in, line)) n += line.empty() ? 0 : 1;
  return n;
}

RunGraphConfig Fig7Config(const std::string& log_path) {
  const daq::RigConfig rig = LoadRig(kBlock1Rig);
  RunGraphConfig g;
  g.log_path = log_path;
  g.model.variants = BuildVariants({}, rig);
  g.daq = DaqConfigFor(rig, kFig7, 0.0);  // as fast as possible
  g.compare.stale_clock = compare::StaleClock::kSample;
  return g;
}

TEST(RunGraph, RunsTheInputThroughEveryStageAndStopsInOrder) {
  const std::string log_path = test::ScratchDir("run_graph") + "/run.lcm";
  const std::int64_t rows = DataRows(kFig7);
  ASSERT_GT(rows, 6900);
  std::int64_t frames = 0;
  {
    RunGraph graph(Fig7Config(log_path));
    const std::atomic<bool> stop{false};
    graph.Run(stop);
    frames = graph.daq_stats().frames_read;
    EXPECT_EQ(frames, rows);
    EXPECT_EQ(graph.bus().decode_error_count(), 0);
    EXPECT_EQ(graph.bus().handler_error_count(), 0);
    EXPECT_EQ(graph.forward_errors(), 0);  // memq://: no network tap
    ASSERT_NE(graph.log(), nullptr);
    EXPECT_EQ(graph.log()->write_errors(), 0);
    EXPECT_GT(graph.model().table_count(), 0);
    const auto summary = graph.compare().Summary();
    ASSERT_EQ(summary.size(), 2u);  // Housner and the complex formulation
    for (const auto& v : summary) {
      EXPECT_GT(v.metrics.samples, 6900) << v.name;  // every sample paired
    }
  }
  lcm::LogFile in(log_path, "r");
  ASSERT_TRUE(in.good());
  std::map<std::string, std::int64_t> last_health;
  std::map<std::string, std::string> last_state;
  std::int64_t index = 0, raw = 0;
  while (const lcm::LogEvent* ev = in.readNextEvent()) {
    ++index;
    if (ev->channel == "RL_RAW") ++raw;
    if (ev->channel != "RL_HEALTH") continue;
    rocklab::health2_t h;
    ASSERT_GE(h.decode(ev->data, 0, ev->datalen), 0);
    last_health[h.node] = index;
    last_state[h.node] = h.state;
  }
  EXPECT_EQ(raw, frames);
  for (const char* node : {"daq", "model", "compare"}) {
    ASSERT_EQ(last_state.count(node), 1u) << node;
    EXPECT_EQ(last_state[node], "stopped") << node;
  }
  EXPECT_LT(last_health["daq"], last_health["model"]);
  EXPECT_LT(last_health["model"], last_health["compare"]);
}

// Oracle: the errors name the option, as the command prints them.
TEST(RunGraph, AnUnwritableLogNamesTheOption) {
  RunGraphConfig g = Fig7Config("/nonexistent-dir/run.lcm");
  try {
    RunGraph graph(g);
    FAIL() << "no error";
  } catch (const OptionError& e) {
    EXPECT_NE(std::string(e.what()).find("--log"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace rocklab::pipeline
