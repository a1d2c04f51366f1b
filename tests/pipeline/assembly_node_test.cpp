// The model node running an assembly live (an assembly variant,
// `NAME:housner:FILE.toml`): driven by a table record sample by sample it
// publishes model_state4_t with every body's state, equal to `simulate
// --assembly`'s run of the same record (pipeline::RunAssembly), and events
// naming the interface.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <set>
#include <string>
#include <vector>

#include "common/direct_bus.h"
#include "model/model_node.h"
#include "model/variant.h"
#include "pipeline/assembly.h"
#include "pipeline/option_error.h"
#include "pipeline/pipeline.h"
#include "rocklab/event2_t.hpp"
#include "rocklab/model_state4_t.hpp"
#include "tests/model/node_messages.h"
#include "tests/scratch.h"
#include "tests/source_paths.h"

namespace rocklab::pipeline {
namespace {

using model::node_messages::Table;
using model::node_messages::Theta;

// A 0.6 s table record at 1 kHz: one cycle of a 2 Hz sine of 6 m/s^2
// (above the three drums' uplift, a/g = 0.27), then still: the column
// lifts, its joints open and strike (seven contact modes: LCC, LLC, RLL,
// RCL, RCR, ...); written with 17 digits so that the node reads the same
// doubles from its RL_TABLE as simulate from the file.
std::vector<double> WriteDrumRecord(const std::string& path) {
  std::vector<double> accel;
  std::ofstream out(path);
  out << "time,accel\n";
  for (int k = 0; k <= 600; ++k) {
    const double t = k * 1e-3;
    accel.push_back(t <= 0.5 ? 6.0 * std::sin(2 * 3.141592653589793 * 2.0 * t) : 0.0);
    char line[80];
    std::snprintf(line, sizeof line, "%.17g,%.17g\n", t, accel.back());
    out << line;
  }
  return accel;
}

// Oracle: `simulate --assembly`'s run (stack::Simulate, CVODE's Adams
// stepping across the samples) of the same record, linear between its
// samples as the node's table is. The node steps with the same Adams
// stopping at every sample; both hold rtol 1e-10 and atol 1e-12 rad, so
// they differ by their integration errors alone, which the impacts carry
// on: 1e-7 rad is ~1e-6 of the peak angle and far below any modelling
// difference; measured 2.7e-8 rad when the node stepped with Dormand-Prince
// 5(4) (docs/models.md, "In the
// model node"). Event times agree to 1.5 us: the root finders locate a
// crossing to ~1e-10 s, and 3e-8 rad moves a crossing at ~0.1 rad/s by
// ~3e-7 s.
TEST(AssemblyNode, StackVariantEqualsSimulateAssemblyOnTheSameRecord) {
  const std::string dir = test::ScratchDir("assembly_node");
  const std::string csv = dir + "/drums.csv";
  const std::vector<double> accel = WriteDrumRecord(csv);
  const std::string toml = test::kSource + "/data/assemblies/drums3.toml";

  ScenarioOptions so;
  so.model = "housner";
  so.accel_csv = csv;
  so.duration_s = 0.6;
  so.rate_hz = 1000.0;
  const AssemblyRun sim = RunAssembly(ReadAssembly(toml), so);
  ASSERT_EQ(sim.names.size(), 3u);

  model::VariantSpec spec = model::ParseVariant("drums:housner:" + toml, std::nullopt);
  ResolveAssemblyVariant(spec);
  ASSERT_TRUE(spec.stack.has_value());
  model::ModelNodeConfig config;
  config.variants.push_back(spec);
  common::DirectBus bus;
  std::vector<rocklab::model_state4_t> states;
  std::vector<rocklab::event2_t> events;
  const common::Subscription s1 = bus.Subscribe<rocklab::model_state4_t>(
      "RL_MODEL_drums", [&](const std::string&, const rocklab::model_state4_t& m) { states.push_back(m); });
  const common::Subscription s2 = bus.Subscribe<rocklab::event2_t>(
      "RL_EVENT", [&](const std::string&, const rocklab::event2_t& e) { events.push_back(e); });
  model::ModelNode node(config, bus);
  const std::int64_t t0 = 1'700'000'000'000'000;  // an epoch utime: model time counts from it
  node.HandleTheta(Theta(t0, 0.0));
  for (std::size_t k = 0; k < accel.size(); ++k) {
    node.HandleTable(Table(t0 + 1000 * static_cast<std::int64_t>(k), accel[k]));
  }
  ASSERT_EQ(states.size(), sim.time_s.size());
  // Compared up to the first grazing contact: an impact whose rebound
  // shuts again within 1e-4 s (its relative rate near the 1e-6 rad/s below
  // which a joint shuts without an impulse). There the model's outcome is
  // discontinuous in the state, and two integrations that differ by 1e-9
  // rad may take either branch (this record has one at 0.4666 s, where the
  // node's joint stayed open 0.4 ms longer than simulate's).
  double compared_until_s = so.duration_s + 1.0;
  std::size_t compared_events = sim.events.size();
  for (std::size_t i = 0; i + 1 < sim.events.size(); ++i) {
    if (sim.events[i + 1].time_s - sim.events[i].time_s < 1e-4) {
      compared_until_s = sim.events[i].time_s - 1e-3;
      compared_events = i;
      break;
    }
  }
  double worst = 0.0, peak = 0.0;
  int open_joints = 0;  // compared samples with a joint between drums open
  std::set<std::string> modes;
  for (std::size_t i = 0; i < states.size() && sim.time_s[i] < compared_until_s; ++i) {
    const rocklab::model_state4_t& m = states[i];
    ASSERT_EQ(m.nbodies, 3);
    ASSERT_EQ(m.seq, static_cast<std::int64_t>(i));
    ASSERT_EQ(m.mode, sim.mode[i]) << "sample " << i;
    open_joints += m.mode[1] != 'C' || m.mode[2] != 'C';
    modes.insert(m.mode);
    for (std::size_t b = 0; b < 3; ++b) {
      ASSERT_NEAR(m.theta[b], sim.theta[b][i], 1e-7) << "body " << b << " sample " << i;
      worst = std::max(worst, std::abs(m.theta[b] - sim.theta[b][i]));
      peak = std::max(peak, std::abs(sim.theta[b][i]));
    }
  }
  std::printf("up to %.4f s: max |theta_node - theta_simulate| = %.3g rad over a peak of %.3g rad, %d samples "
              "with a joint open, %zu modes\n",
              compared_until_s, worst, peak, open_joints, modes.size());
  EXPECT_GT(peak, 1e-3);  // the drums did rock
  EXPECT_GT(open_joints, 50);
  EXPECT_GE(modes.size(), 4u);
  // The events: the same kinds at the same times, each naming its interface
  // and the bodies on either side.
  ASSERT_GE(events.size(), compared_events);
  int impacts = 0;
  for (std::size_t i = 0; i < compared_events; ++i) {
    const AssemblyEvent& e = sim.events[i];
    EXPECT_EQ(events[i].source, "drums");
    EXPECT_NEAR((events[i].utime - t0) * 1e-6, e.time_s, 1.5e-6) << events[i].detail;
    const std::string below = e.interface == 0 ? "table" : sim.names[static_cast<std::size_t>(e.interface) - 1];
    EXPECT_NE(events[i].detail.find("interface " + std::to_string(e.interface) + " (" + below + "/" +
                                    sim.names[static_cast<std::size_t>(e.interface)] + "), mode " + e.mode),
              std::string::npos)
        << events[i].detail;
    impacts += e.kind == model::EventKind::kImpact;
  }
  EXPECT_GT(impacts, 0);
  // Per body: alpha of a 0.4 m x 0.5 m drum on its own width, atan(0.2 / 0.25).
  EXPECT_NEAR(states.back().alpha[2], std::atan(0.8), 1e-15);
}

// A model the stack cannot take is refused naming the file; a one-body
// assembly runs as its single block (model_state3_t, as today).
TEST(AssemblyNode, ComplexStackRefusedAndOneBodyIsTheSingleBlock) {
  const std::string toml = test::kSource + "/data/assemblies/drums3.toml";
  model::VariantSpec complex = model::ParseVariant("c:complex:" + toml, std::nullopt);
  try {
    ResolveAssemblyVariant(complex);
    FAIL() << "complex took a stack";
  } catch (const OptionError& e) {
    EXPECT_NE(std::string(e.what()).find("drums3.toml"), std::string::npos) << e.what();
  }
  // As `rocklab model` and `rocklab run` build their variants.
  const daq::RigConfig rig = LoadRig(test::kLabRig);
  const std::vector<model::VariantSpec> built = BuildVariants({"d:housner:" + toml}, rig, 1e-9);
  ASSERT_TRUE(built.at(0).stack.has_value());
  EXPECT_EQ(built.at(0).stack->bodies(), 3);
  EXPECT_EQ(built.at(0).options.rtol, 1e-9);
  EXPECT_EQ(built.at(0).body_names, (std::vector<std::string>{"drum1", "drum2", "drum3"}));
  try {
    BuildVariants({"c:complex:" + toml}, rig, 1e-10);
    FAIL() << "complex took a stack";
  } catch (const OptionError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("--variant 'c:complex:", 0), 0u) << e.what();
  }
  const std::string dir = test::ScratchDir("assembly_node_one");
  const std::string one = dir + "/one.toml";
  std::ofstream(one) << "[[body]]\nname = \"b\"\nwidth_m = 0.2\nheight_m = 0.8\nmass_kg = 50.0\n";
  model::VariantSpec block = model::ParseVariant("b:housner:" + one, std::nullopt);
  ResolveAssemblyVariant(block);
  EXPECT_FALSE(block.stack.has_value());
  // Oracle: a rectangle's alpha = atan(b / h), mu = 1 - 1.5 sin^2(alpha).
  EXPECT_NEAR(block.params.alpha, std::atan(0.25), 1e-15);
  EXPECT_NEAR(block.params.mu, 1 - 1.5 * std::pow(std::sin(std::atan(0.25)), 2), 1e-15);
}

}  // namespace
}  // namespace rocklab::pipeline
