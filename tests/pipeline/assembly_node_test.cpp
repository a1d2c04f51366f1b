// The model node running an assembly live (an assembly variant,
// `NAME:housner:FILE.toml`): driven by a table record sample by sample it
// publishes model_state4_t with every body's state, equal to `simulate
// --assembly`'s run of the same record (pipeline::RunAssembly), and events
// naming the interface.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <set>
#include <string>
#include <vector>

#include "common/direct_bus.h"
#include "model/excitation.h"
#include "model/stack.h"
#include "model/model_node.h"
#include "model/variant.h"
#include "pipeline/assembly.h"
#include "pipeline/option_error.h"
#include "pipeline/pipeline.h"
#include "rocklab/block_state2_t.hpp"
#include "rocklab/event2_t.hpp"
#include "rocklab/model_state4_t.hpp"
#include "tests/model/node_messages.h"
#include "tests/scratch.h"
#include "tests/source_paths.h"

namespace rocklab::pipeline {
namespace {

using model::node_messages::Table;
using model::node_messages::Theta;

// A model node of one variant on a DirectBus, with what it publishes on
// RL_MODEL_<name> and RL_EVENT gathered.
struct NodeOnABus {
  explicit NodeOnABus(const model::VariantSpec& spec)
      : states_sub(bus.Subscribe<rocklab::model_state4_t>(
            "RL_MODEL_" + spec.name,
            [this](const std::string&, const rocklab::model_state4_t& m) { states.push_back(m); })),
        events_sub(bus.Subscribe<rocklab::event2_t>(
            "RL_EVENT", [this](const std::string&, const rocklab::event2_t& e) { events.push_back(e); })),
        node(Config(spec), bus) {}
  static model::ModelNodeConfig Config(const model::VariantSpec& spec) {
    model::ModelNodeConfig config;
    config.variants.push_back(spec);
    return config;
  }
  common::DirectBus bus;
  std::vector<rocklab::model_state4_t> states;
  std::vector<rocklab::event2_t> events;
  const common::Subscription states_sub, events_sub;
  model::ModelNode node;
};

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
  NodeOnABus on(spec);
  std::vector<rocklab::model_state4_t>& states = on.states;
  std::vector<rocklab::event2_t>& events = on.events;
  model::ModelNode& node = on.node;
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

// The drums3 variant as `rocklab model` builds it, and the stack its node
// steps: the same RunOptions (rtol, restitution, Adams).
model::VariantSpec DrumsVariant() {
  model::VariantSpec spec = model::ParseVariant("drums:housner:" + test::kSource + "/data/assemblies/drums3.toml",
                                                std::nullopt);
  ResolveAssemblyVariant(spec);
  return spec;
}
model::stack::RunOptions NodeRunOptions(const model::VariantSpec& spec) {
  model::stack::RunOptions ro;
  ro.rtol = spec.options.rtol;
  ro.restitution = spec.restitution;
  ro.integrator = model::Integrator::kAdams;
  return ro;
}

// RL_BODIES of sample clock `utime` (us): per body theta and theta_dot in
// the measurement's sign (clockwise positive), the other fields 0.
rocklab::block_state2_t Bodies(std::int64_t utime, const std::vector<double>& theta,
                               const std::vector<double>& theta_dot) {
  rocklab::block_state2_t m{};
  m.utime = utime;
  m.nbodies = static_cast<std::int32_t>(theta.size());
  m.theta = theta;
  m.theta_dot = theta_dot;
  const auto n = theta.size();
  m.theta_mirror.assign(n, 0.0);
  m.theta_camera.assign(n, 0.0);
  m.sliding.assign(n, 0.0);
  m.jump.assign(n, 0.0);
  m.twist.assign(n, 0.0);
  m.out_of_plane.assign(n, 0.0);
  m.leds_used.assign(n, 0);
  m.flags.assign(n, 0);
  return m;
}

// Oracle: the continuous run. The drums stepped by stack::Stepper (the
// loop of simulate --assembly) from rest on the record's samples to t0,
// while rocking with a joint between drums open; the node is given the
// table from t0 on and RL_BODIES carrying that run's state at t0, and from
// there must follow the run. Both integrate the same piecewise-linear table
// with Adams at rtol 1e-10 and atol 1e-12 rad, the node restarted at t0
// from the run's state (passed exactly but for the relative angles'
// round-off, 1e-17 rad): they differ by the integrators' errors alone,
// carried through the impacts, as the node and simulate of
// StackVariantEqualsSimulateAssemblyOnTheSameRecord, whose 1e-7 rad (~1e-6
// of the peak angle) and 1.5 us on event times hold here too.
TEST(AssemblyNode, StackStartsFromTheMeasuredBodiesAndFollowsTheRun) {
  // WriteDrumRecord's cycle of 6 m/s^2 at 2 Hz, then 0.7 s still.
  std::vector<double> accel;
  for (int k = 0; k <= 1200; ++k) {
    const double t = k * 1e-3;
    accel.push_back(t <= 0.5 ? 6.0 * std::sin(2 * 3.141592653589793 * 2.0 * t) : 0.0);
  }
  const model::VariantSpec spec = DrumsVariant();
  ASSERT_TRUE(spec.stack.has_value());
  model::stack::Stepper run(*spec.stack, NodeRunOptions(spec));
  const int n = 3;
  // The run's samples (the stack's sign: counter-clockwise).
  std::vector<std::array<double, model::stack::kMaxBodies>> theta, theta_dot;
  std::vector<std::string> modes;
  std::vector<model::stack::Event> run_events;
  std::size_t k0 = 0;
  for (std::size_t k = 0; k < accel.size(); ++k) {
    const double t = static_cast<double>(k) * 1e-3;
    run.Step(t, accel[k]);
    std::array<double, model::stack::kMaxBodies> th{}, thd{};
    run.BodyStates(th.data(), thd.data());
    theta.push_back(th);
    theta_dot.push_back(thd);
    modes.push_back(model::stack::ModeName(run.mode(), n));
    // t0: the first sample after the record's first grazing contact
    // (0.4666 s: StackVariantEqualsSimulateAssemblyOnTheSameRecord) with a
    // joint between drums open and every open joint well past the rest
    // threshold (2e-3 rad).
    if (k0 == 0 && t > 0.47 && (run.mode()[1] != 0 || run.mode()[2] != 0)) {
      bool clear = true;
      for (int b = 0; b < n; ++b) {
        const double rel = th[static_cast<std::size_t>(b)] - (b > 0 ? th[static_cast<std::size_t>(b) - 1] : 0.0);
        clear = clear && (run.mode()[static_cast<std::size_t>(b)] == 0 ? rel == 0.0 : std::abs(rel) > 5e-3);
      }
      if (clear) k0 = k;
    }
    for (const model::stack::Event& e : run.events()) run_events.push_back(e);
    run.ClearEvents();
  }
  ASSERT_GT(k0, 0u) << "no joint between drums opened: the test does not test";
  std::printf("t0 = %.3f s in mode %s\n", static_cast<double>(k0) * 1e-3, modes[k0].c_str());

  NodeOnABus on(spec);
  common::DirectBus& bus = on.bus;
  std::vector<rocklab::model_state4_t>& states = on.states;
  std::vector<rocklab::event2_t>& events = on.events;
  model::ModelNode& node = on.node;
  const std::int64_t t0 = 1'700'000'000'000'000 + 1000 * static_cast<std::int64_t>(k0);
  std::vector<double> th0(n), thd0(n);
  for (std::size_t b = 0; b < 3; ++b) {
    th0[b] = 0.0 - theta[k0][b];  // the measurement's sign
    thd0[b] = 0.0 - theta_dot[k0][b];
  }
  // As the DAQ sends a sample of a rig of several bodies: RL_THETA (the
  // bottom body), RL_BODIES, RL_TABLE; through the bus.
  bus.Publish("RL_THETA", Theta(t0, th0[0]));
  bus.Publish("RL_BODIES", Bodies(t0, th0, thd0));
  for (std::size_t k = k0; k < accel.size(); ++k) {
    rocklab::table_state_t table = Table(t0 + 1000 * static_cast<std::int64_t>(k - k0), accel[k]);
    table.seq = static_cast<std::int64_t>(k);
    bus.Publish("RL_TABLE", table);
  }
  EXPECT_EQ(node.start_refusals(), 0);
  ASSERT_EQ(states.size(), accel.size() - k0);
  EXPECT_EQ(states.front().mode, modes[k0]);
  // Compared up to the run's first grazing contact after t0 (see
  // StackVariantEqualsSimulateAssemblyOnTheSameRecord).
  double compared_until_s = 1e9;
  std::size_t first_event = 0;
  while (first_event < run_events.size() && run_events[first_event].time_s <= static_cast<double>(k0) * 1e-3) {
    ++first_event;
  }
  std::size_t compared_events = run_events.size() - first_event;
  for (std::size_t i = first_event; i + 1 < run_events.size(); ++i) {
    if (run_events[i + 1].time_s - run_events[i].time_s < 1e-4) {
      compared_until_s = run_events[i].time_s - 1e-3;
      compared_events = i - first_event;
      break;
    }
  }
  double worst = 0.0, peak = 0.0;
  int open_joints = 0;
  std::size_t compared = 0;
  for (std::size_t i = 0; i < states.size() && static_cast<double>(k0 + i) * 1e-3 < compared_until_s; ++i) {
    const rocklab::model_state4_t& m = states[i];
    ASSERT_EQ(m.mode, modes[k0 + i]) << "sample " << k0 + i;
    open_joints += m.mode[1] != 'C' || m.mode[2] != 'C';
    for (std::size_t b = 0; b < 3; ++b) {
      ASSERT_NEAR(m.theta[b], 0.0 - theta[k0 + i][b], 1e-7) << "body " << b << " sample " << k0 + i;
      worst = std::max(worst, std::abs(m.theta[b] + theta[k0 + i][b]));
      peak = std::max(peak, std::abs(theta[k0 + i][b]));
    }
    ++compared;
  }
  std::printf("from t0 over %zu samples (to %.4f s): max |theta_node - theta_run| = %.3g rad over a peak of "
              "%.3g rad, %d with a joint between drums open, %zu events compared\n",
              compared, compared_until_s, worst, peak, open_joints, compared_events);
  EXPECT_GT(compared, 100u);
  EXPECT_GT(open_joints, 10);
  ASSERT_GE(events.size(), compared_events);
  EXPECT_GT(compared_events, 0u);
  for (std::size_t i = 0; i < compared_events; ++i) {
    const model::stack::Event& e = run_events[first_event + i];
    EXPECT_NEAR((events[i].utime - t0) * 1e-6, e.time_s - static_cast<double>(k0) * 1e-3, 1.5e-6)
        << events[i].detail;
    // The event codes as values (copies: the constants have no definition to bind to).
    const int kind = e.kind == model::EventKind::kImpact   ? int{rocklab::event2_t::IMPACT}
                     : e.kind == model::EventKind::kUplift ? int{rocklab::event2_t::UPLIFT}
                     : e.kind == model::EventKind::kRest   ? int{rocklab::event2_t::REST}
                                                           : int{rocklab::event2_t::OVERTURN};
    EXPECT_EQ(int{events[i].kind}, kind) << events[i].detail;
  }
}

// A measured state that no contact mode admits (the top drum turned 1.7
// rad on the middle one: past overturning) is refused, counted and said,
// and the stack starts at rest; one within the rest threshold is at rest
// too (noise opens no joint), without a refusal. A reset (the table utime
// going back) starts again from the newest RL_BODIES.
TEST(AssemblyNode, AMeasuredStateNoModeAdmitsIsRefusedAndTheStackStartsAtRest) {
  NodeOnABus on(DrumsVariant());
  common::DirectBus& bus = on.bus;
  std::vector<rocklab::model_state4_t>& states = on.states;
  std::vector<rocklab::event2_t>& events = on.events;
  model::ModelNode& node = on.node;
  const std::int64_t t0 = 5'000'000;
  bus.Publish("RL_THETA", Theta(t0, 0.01));
  bus.Publish("RL_BODIES", Bodies(t0, {0.01, 0.012, 1.712}, {0.1, 0.1, 0.0}));
  for (int k = 0; k < 10; ++k) bus.Publish("RL_TABLE", Table(t0 + 1000 * k, 0.0));
  EXPECT_EQ(node.start_refusals(), 1);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(int{events[0].kind}, int{rocklab::event2_t::BAD_SAMPLE});
  EXPECT_EQ(events[0].utime, t0);
  EXPECT_NE(events[0].detail.find("measured start refused (interface 2 turned by -1.7 rad"), std::string::npos)
      << events[0].detail;
  ASSERT_EQ(states.size(), 10u);
  for (const auto& m : states) {
    EXPECT_EQ(m.mode, "CCC");
    for (double th : m.theta) EXPECT_EQ(th, 0.0);
  }
  // A new run (utime back): noise below the rest threshold starts at rest
  // without a refusal; another body count is refused.
  bus.Publish("RL_THETA", Theta(1'000'000, 1e-3));
  bus.Publish("RL_BODIES", Bodies(1'000'000, {1e-3, 2.5e-3, 1.5e-3}, {0.05, 0.0, 0.0}));
  bus.Publish("RL_TABLE", Table(1'000'000, 0.0));
  EXPECT_EQ(node.resets(), 1);
  EXPECT_EQ(node.start_refusals(), 1);
  EXPECT_EQ(states.back().mode, "CCC");
  bus.Publish("RL_THETA", Theta(500'000, 0.01));
  bus.Publish("RL_BODIES", Bodies(500'000, {0.01, 0.02}, {0.0, 0.0}));
  bus.Publish("RL_TABLE", Table(500'000, 0.0));
  EXPECT_EQ(node.start_refusals(), 2);
  EXPECT_NE(events.back().detail.find("RL_BODIES carries 2 bodies, the stack 3"), std::string::npos)
      << events.back().detail;
  EXPECT_EQ(states.back().mode, "CCC");
  // And a state some mode admits starts there: the bottom drum on its
  // right corner (clockwise, 0.01 rad), the others riding on it.
  bus.Publish("RL_THETA", Theta(100'000, 0.01));
  bus.Publish("RL_BODIES", Bodies(100'000, {0.01, 0.01, 0.0105}, {0.0, 0.0, 0.0}));
  bus.Publish("RL_TABLE", Table(100'000, 0.0));
  EXPECT_EQ(node.start_refusals(), 2);
  EXPECT_EQ(states.back().mode, "RCC");
  EXPECT_NEAR(states.back().theta[2], 0.01, 1e-15);
}

// Figure 8's sine (6 mm at 5 Hz) under five drums hits impacts resolved
// only with the pivots held (AssemblyCli.ImpactsResolvedWithPivotsHeld...):
// live, each such impact's RL_EVENT names the rule and the node counts
// them, as many as the stack's own Stepper on the same samples counts.
TEST(AssemblyNode, ImpactsResolvedByTheModelsAssumptionsAreSaidAndCounted) {
  model::VariantSpec spec =
      model::ParseVariant("drums:housner:" + test::kSource + "/data/assemblies/drums5.toml", std::nullopt);
  ResolveAssemblyVariant(spec);
  ASSERT_TRUE(spec.stack.has_value());
  model::ModelNodeConfig config;
  config.variants.push_back(spec);
  common::DirectBus bus;
  int held_events = 0, preload_events = 0;
  const common::Subscription s2 =
      bus.Subscribe<rocklab::event2_t>("RL_EVENT", [&](const std::string&, const rocklab::event2_t& e) {
        held_events += e.detail.find(", resolved with pivots held") != std::string::npos;
        preload_events += e.detail.find(", resolved within the preloads") != std::string::npos;
      });
  model::ModelNode node(config, bus);
  model::stack::Stepper oracle(*spec.stack, NodeRunOptions(spec));
  const auto sine = model::MakeSine({0.006, 5.0, 20.0, 0.0});
  node.HandleTheta(Theta(0, 0.0));
  // Up to the first held pivots and one more second (20 s at most).
  long until = 20000;
  for (long k = 0; k <= until; ++k) {
    const double t = static_cast<double>(k) * 1e-3;
    const double a = sine->TableAcceleration(t);
    node.HandleTable(Table(1000 * k, a));
    oracle.Step(t, a);
    if (until == 20000 && node.impacts_held_pivots() > 0) until = std::min(until, k + 1000);
  }
  std::printf("to %.1f s: %lld impacts within the preloads, %lld with pivots held\n", static_cast<double>(until) * 1e-3,
              static_cast<long long>(node.impacts_preload()), static_cast<long long>(node.impacts_held_pivots()));
  EXPECT_GT(node.impacts_held_pivots(), 0);
  EXPECT_EQ(node.impacts_held_pivots(), oracle.impacts_held_pivots());
  EXPECT_EQ(node.impacts_preload(), oracle.impacts_preload());
  EXPECT_EQ(held_events, node.impacts_held_pivots());
  EXPECT_EQ(preload_events, node.impacts_preload());
  EXPECT_EQ(node.failures(), 0);
}

}  // namespace
}  // namespace rocklab::pipeline
