// `rocklab simulate --assembly FILE.toml` as a user runs it, and the
// assembly file's reader (pipeline/assembly.h): a one-body assembly is the
// single block, a frame its equivalent block, a stack the stack model's run;
// bad files are named by file, line and key.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "model/excitation.h"
#include "model/stack.h"
#include "pipeline/assembly.h"
#include "pipeline/option_error.h"
#include "tests/source_paths.h"
#include "tests/tools/run_cli.h"

namespace rocklab::test {
namespace {

// A CSV's rows as text fields (header first).
std::vector<std::vector<std::string>> AssemblyCsvRows(const std::string& path) {
  std::vector<std::vector<std::string>> rows;
  std::istringstream in(ReadFile(path));
  for (std::string line; std::getline(in, line);) {
    std::vector<std::string> fields;
    std::istringstream l(line);
    for (std::string f; std::getline(l, f, ',');) fields.push_back(f);
    rows.push_back(fields);
  }
  return rows;
}

std::string Digits17(double v) {
  char text[40];
  std::snprintf(text, sizeof text, "%.17g", v);
  return text;
}

const std::vector<std::string> kAssemblySine{"--excitation", "sine:amp=0.02,freq=2,duration=10,start=0",
                                             "--duration", "3", "--rate", "100"};

std::vector<std::string> SimulateArgs(std::vector<std::string> head) {
  head.insert(head.begin(), "simulate");
  head.insert(head.end(), kAssemblySine.begin(), kAssemblySine.end());
  return head;
}

// Oracle: the single-block path (`simulate --alpha --p --mu`) with the
// block's alpha, p and mu as `params` gives them (params_cli_test holds
// those to Table 1's closed forms): a one-body assembly writes the same
// time, theta and theta_dot, to every digit the CSV prints, and its mode is
// C at rest and the pivot's side when rocking (theta > 0: R).
TEST(AssemblyCli, OneBodyIsTheSingleBlockToEveryDigit) {
  const std::string dir = ScratchDir("assembly_one_body");
  WriteFile(dir + "/block.toml",
            "[[body]]\nname = \"block\"\nwidth_m = 0.25\nheight_m = 1.0\ndepth_m = 0.2\ndensity_kg_m3 = 2500\n");
  const CliResult params = RunCli({"params", "--width", "0.25", "--height", "1.0", "--json"});
  ASSERT_EQ(params.exit_code, 0) << params.err;
  const auto p = nlohmann::json::parse(params.out);
  const CliResult single = RunCli(SimulateArgs({"--alpha", Digits17(p.at("alpha").get<double>()), "--p",
                                                Digits17(p.at("p").get<double>()), "--mu",
                                                Digits17(p.at("mu").get<double>()), "--out", dir + "/single.csv"}));
  ASSERT_EQ(single.exit_code, 0) << single.err;
  const CliResult assembly =
      RunCli(SimulateArgs({"--assembly", dir + "/block.toml", "--out", dir + "/assembly.csv", "--json"}));
  ASSERT_EQ(assembly.exit_code, 0) << assembly.err;
  const auto a = AssemblyCsvRows(dir + "/assembly.csv");
  const auto s = AssemblyCsvRows(dir + "/single.csv");
  ASSERT_EQ(a.front(), (std::vector<std::string>{"time", "theta_1", "theta_dot_1", "mode"}));
  ASSERT_EQ(a.size(), s.size());
  ASSERT_EQ(a.size(), 302u);
  int rocking = 0;
  for (std::size_t i = 1; i < a.size(); ++i) {
    ASSERT_EQ(a[i].size(), 4u);
    EXPECT_EQ(std::vector<std::string>(a[i].begin(), a[i].begin() + 3), s[i]) << "row " << i;
    const double theta = std::stod(a[i][1]);
    if (a[i][3] != "C") ++rocking;
    EXPECT_EQ(a[i][3], theta == 0 ? "C" : (theta > 0 ? "R" : "L")) << "row " << i;
  }
  EXPECT_GT(rocking, 50);
  const auto j = nlohmann::json::parse(assembly.out);
  EXPECT_EQ(j.at("kind"), "block");
  EXPECT_EQ(j.at("alpha").get<double>(), p.at("alpha").get<double>());
  EXPECT_EQ(j.at("bodies").at(0).at("name"), "block");
  EXPECT_GT(j.at("impacts").get<int>(), 0);
}

// Oracle: the frame is its equivalent block (model::stack::FrameEquivalent,
// held to the frame's energies in StackFrame.TheFrameIsItsEquivalentBlock):
// through the command line, Housner's and the complex model's angles agree
// with the single block's to 1e-9 relative (of the peak angle).
TEST(AssemblyCli, AFrameIsItsEquivalentBlock) {
  const std::string dir = ScratchDir("assembly_frame");
  const std::string toml = kSource + "/data/assemblies/portal_frame.toml";
  model::stack::Frame frame;
  frame.columns = 2;
  frame.column_width_m = 0.2;
  frame.column_height_m = 1.5;
  frame.column_mass_kg = 150.0;
  frame.beam_mass_kg = 200.0;
  const model::BlockParams b = model::stack::FrameEquivalent(frame);
  for (const char* kind : {"housner", "complex"}) {
    const CliResult single =
        RunCli(SimulateArgs({"--model", kind, "--alpha", Digits17(b.alpha), "--p", Digits17(b.p), "--mu",
                             Digits17(b.mu), "--out", dir + "/single.csv"}));
    ASSERT_EQ(single.exit_code, 0) << single.err;
    const CliResult assembly = RunCli(SimulateArgs({"--model", kind, "--assembly", toml, "--out", dir + "/frame.csv"}));
    ASSERT_EQ(assembly.exit_code, 0) << assembly.err;
    const auto a = AssemblyCsvRows(dir + "/frame.csv");
    const auto s = AssemblyCsvRows(dir + "/single.csv");
    ASSERT_EQ(a.size(), s.size());
    double peak = 0;
    for (std::size_t i = 1; i < s.size(); ++i) peak = std::max(peak, std::abs(std::stod(s[i][1])));
    ASSERT_GT(peak, 1e-3) << kind << ": the frame must rock";
    for (std::size_t i = 1; i < a.size(); ++i) {
      EXPECT_NEAR(std::stod(a[i][1]), std::stod(s[i][1]), 1e-9 * peak) << kind << " row " << i;
    }
  }
}

// Oracles: (1) the stack model's own run (model::stack::Simulate, held to
// the reference integration of tests/model/oracle/stack_oracle.py): the
// CSV is its samples, angles negated into the single block's convention
// (exactly: the same computation), its modes by name, and its events
// naming interface and body; (2) the issue's uplift from rest: the statue
// (b2/h2 = 0.25) lifts first, alone, where the table's acceleration
// A w^2 |sin(w t)| first reaches 0.25 g, to 1e-6 s (the root finder's).
TEST(AssemblyCli, AStackIsTheStackModelsRun) {
  const std::string dir = ScratchDir("assembly_stack");
  const std::string toml = kSource + "/data/assemblies/statue_on_pedestal.toml";
  const CliResult r = RunCli(SimulateArgs(
      {"--assembly", toml, "--out", dir + "/stack.csv", "--events", dir + "/events.csv", "--json"}));
  ASSERT_EQ(r.exit_code, 0) << r.err;

  const model::stack::Stack stack({model::stack::Body::Rectangle(0.5, 0.4, 0.5 * 0.5 * 0.4 * 2400),
                                   model::stack::Body::Rectangle(0.2, 0.8, 0.2 * 0.2 * 0.8 * 2700)});
  const auto sine = model::MakeSine({0.02, 2.0, 10.0, 0.0});
  model::stack::RunOptions options;
  options.duration_s = 3.0;
  options.rate_hz = 100.0;
  const model::stack::Run run = model::stack::Simulate(stack, *sine, options);

  const auto rows = AssemblyCsvRows(dir + "/stack.csv");
  ASSERT_EQ(rows.front(),
            (std::vector<std::string>{"time", "theta_1", "theta_dot_1", "theta_2", "theta_dot_2", "mode"}));
  ASSERT_EQ(rows.size(), run.time_s.size() + 1);
  for (std::size_t i = 0; i < run.time_s.size(); ++i) {
    const auto& row = rows[i + 1];
    ASSERT_EQ(row.size(), 6u);
    EXPECT_EQ(std::stod(row[0]), run.time_s[i]);
    for (int k = 0; k < 2; ++k) {
      EXPECT_EQ(std::stod(row[static_cast<std::size_t>(1 + 2 * k)]), -run.theta[i][static_cast<std::size_t>(k)]);
      EXPECT_EQ(std::stod(row[static_cast<std::size_t>(2 + 2 * k)]), -run.theta_dot[i][static_cast<std::size_t>(k)]);
    }
    EXPECT_EQ(row[5], model::stack::ModeName(run.mode[i], 2));
  }

  const auto events = AssemblyCsvRows(dir + "/events.csv");
  ASSERT_EQ(events.front(), (std::vector<std::string>{"time", "kind", "interface", "body", "mode"}));
  ASSERT_EQ(events.size(), run.events.size() + 1);
  ASSERT_GE(run.events.size(), 3u);
  const char* names[] = {"pedestal", "statue"};
  for (std::size_t i = 0; i < run.events.size(); ++i) {
    const auto& e = run.events[i];
    EXPECT_NEAR(std::stod(events[i + 1][0]), e.time_s, 1e-9);
    EXPECT_EQ(events[i + 1][1], model::ToString(e.kind));
    EXPECT_EQ(events[i + 1][2], std::to_string(e.interface));
    EXPECT_EQ(events[i + 1][3], names[e.interface]);
    EXPECT_EQ(events[i + 1][4], model::stack::ModeName(e.after, 2));
  }
  const double w = 2 * M_PI * 2.0, g = model::kGravity;
  EXPECT_EQ(events[1][1], "uplift");
  EXPECT_EQ(events[1][3], "statue");
  EXPECT_NEAR(std::stod(events[1][0]), std::asin(0.25 * g / (0.02 * w * w)) / w, 1e-6);

  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("kind"), "stack");
  EXPECT_TRUE(j.at("alpha").is_null());
  EXPECT_EQ(j.at("bodies").size(), 2u);
  EXPECT_EQ(j.at("bodies").at(1).at("name"), "statue");
  EXPECT_EQ(j.at("samples").get<std::size_t>(), run.time_s.size());
  // The impacts that needed the model's assumptions, as the run counted them.
  EXPECT_EQ(j.at("impacts_preload").get<int>(), run.impacts_preload);
  EXPECT_EQ(j.at("impacts_held_pivots").get<int>(), run.impacts_held_pivots);
}

// Figure 8's sine (6 mm at 5 Hz) under five drums: some impacts have no
// post-impact state whose impulses all push and are resolved with the
// pivots held (docs/models.md). The command says how many, in --json and
// as a warning naming the file, the same count the stack model's run gives.
TEST(AssemblyCli, ImpactsResolvedWithPivotsHeldAreCountedAndSaid) {
  const std::string dir = ScratchDir("assembly_held");
  const std::string toml = kSource + "/data/assemblies/drums5.toml";
  const CliResult r = RunCli({"simulate", "--assembly", toml, "--model", "housner", "--excitation",
                              "sine:amp=0.006,freq=5,duration=20,start=0", "--duration", "20", "--rate", "100",
                              "--out", dir + "/drums.csv", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  const int held = j.at("impacts_held_pivots").get<int>();
  EXPECT_GT(held, 0);
  EXPECT_LE(held + j.at("impacts_preload").get<int>(), j.at("impacts").get<int>());
  EXPECT_NE(r.err.find("drums5.toml: " + std::to_string(held) + " impacts resolved only with pivots held"),
            std::string::npos)
      << r.err;
}

// Oracle: the single block (`simulate --alpha --p --mu`, the statue's
// alpha, p and Housner's mu from `params`). While the pedestal stays
// closed (the mode's first letter C throughout, checked), the statue rocks
// on a fixed base, i.e. as that block on the table: its angle, in the
// single block's sign, agrees to 1e-7 rad at every sample (two
// integrators in different coordinates at rtol 1e-10, as
// StackRun.OneBodyIsRocklabsHousnerModel), and each event's mode is the
// next sample's.
TEST(AssemblyCli, AStatueOnAStillPedestalIsItsSingleBlock) {
  const std::string dir = ScratchDir("assembly_statue_block");
  const std::string toml = kSource + "/data/assemblies/statue_on_pedestal.toml";
  const CliResult r =
      RunCli(SimulateArgs({"--assembly", toml, "--out", dir + "/stack.csv", "--events", dir + "/events.csv"}));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const CliResult params = RunCli({"params", "--width", "0.2", "--height", "0.8", "--json"});
  ASSERT_EQ(params.exit_code, 0) << params.err;
  const auto p = nlohmann::json::parse(params.out);
  const CliResult single = RunCli(SimulateArgs({"--alpha", Digits17(p.at("alpha").get<double>()), "--p",
                                                Digits17(p.at("p").get<double>()), "--mu",
                                                Digits17(p.at("mu_housner").get<double>()), "--out",
                                                dir + "/single.csv"}));
  ASSERT_EQ(single.exit_code, 0) << single.err;
  const auto stack = AssemblyCsvRows(dir + "/stack.csv");
  const auto block = AssemblyCsvRows(dir + "/single.csv");
  ASSERT_EQ(stack.size(), block.size());
  double peak = 0;
  for (std::size_t i = 1; i < stack.size(); ++i) {
    ASSERT_EQ(stack[i][5][0], 'C') << "the pedestal moved at row " << i << ": the oracle does not hold";
    EXPECT_NEAR(std::stod(stack[i][3]), std::stod(block[i][1]), 1e-7) << "t " << stack[i][0];
    peak = std::max(peak, std::abs(std::stod(block[i][1])));
  }
  EXPECT_GT(peak, 0.05);
  const auto events = AssemblyCsvRows(dir + "/events.csv");
  ASSERT_GT(events.size(), 3u);
  for (std::size_t e = 1; e < events.size(); ++e) {
    const double t = std::stod(events[e][0]);
    std::size_t i = 1;
    while (i < stack.size() && std::stod(stack[i][0]) <= t) ++i;
    if (i < stack.size()) {
      EXPECT_EQ(events[e][4], stack[i][5]) << "event at " << t << " s";
    }
  }
}

// The reader's messages: each bad file names the file, the line and the key.
std::string AssemblyError(const std::string& text) {
  try {
    pipeline::ParseAssembly(text, "a.toml");
  } catch (const pipeline::OptionError& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(AssemblyFile, BadFilesNameFileLineAndKey) {
  const std::string body = "[[body]]\nname = \"b\"\nwidth_m = 0.2\nheight_m = 1.0\nmass_kg = 50\n";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"[[body]]\nname = \"b\"\nheight_m = 1.0\nmass_kg = 50\n", "a.toml:1: key 'body.width_m' is missing"},
      {"[[body]]\nname = \"b\"\nwidth_m = -0.2\nheight_m = 1.0\nmass_kg = 50\n",
       "a.toml:3: key 'body.width_m' must be in [0.001, 100] m, got -0.2"},
      {body + "colour = \"red\"\n", "a.toml:6: key 'body.colour' is not an assembly key"},
      {body + "depth_m = 0.2\ndensity_kg_m3 = 2000\n", "a.toml:5: key 'body.mass_kg' is given with depth_m"},
      {"[[body]]\nname = \"b\"\nwidth_m = \"wide\"\nheight_m = 1.0\nmass_kg = 50\n",
       "a.toml:3: key 'body.width_m' must be a number"},
      {"[[body]]\nname = \"b\"\nwidth_m = 0.2\nheight_m = 1.0\n", "key 'body.mass_kg' is missing"},
      {body + body, "key 'body.name' repeats body 'b'"},
      {body + "[[body]]\nname = \"c\"\npolygon = \"p.csv\"\nmass_kg = 5\n",
       "a.toml:8: key 'body.polygon' is refused in a stack of 2 bodies"},
      {body + "[[interface]]\nrestitution = 1.5\n", "a.toml:7: key 'interface.restitution' must be in (0, 1]"},
      {body + "[[interface]]\n[[interface]]\n", "key 'interface' lists 2 interfaces for 1 bodies"},
      {"[frame]\ncolumns = 2.5\n", "a.toml:2: key 'frame.columns' must be an integer"},
      {"title = 3\n", "a.toml:1: key 'body' is missing"},
      {body + "speed = 3\n", "a.toml:6: key 'body.speed' is not an assembly key"},
      {"[[body]]\nname = \"b\"\n[[body]]\n", "key 'body.width_m' is missing"},
  };
  for (const auto& [text, expected] : cases) {
    const std::string what = AssemblyError(text);
    EXPECT_NE(what.find("--assembly: "), std::string::npos) << what;
    EXPECT_NE(what.find(expected), std::string::npos) << "file:\n" << text << "\nmessage: " << what;
  }
  EXPECT_EQ(AssemblyError(body), "(accepted)");
}

// Oracle: a polygon section of the same rectangle gives a one-body
// assembly the rectangle's alpha, p and mu (model/block.h's two routes to
// them, 1e-12); an asymmetric polygon is refused naming the key.
TEST(AssemblyFile, AOneBodyPolygonIsItsSection) {
  const std::string dir = ScratchDir("assembly_polygon");
  WriteFile(dir + "/rect.csv", "x,z\n-0.125,0\n0.125,0\n0.125,1\n-0.125,1\n");
  WriteFile(dir + "/leaning.csv", "x,z\n-0.125,0\n0.125,0\n0.3,1\n0.05,1\n");
  const auto rect = pipeline::EquivalentBlock(
      pipeline::ParseAssembly("[[body]]\nname = \"b\"\nwidth_m = 0.25\nheight_m = 1\nmass_kg = 1\n", dir + "/a.toml"));
  const auto poly = pipeline::EquivalentBlock(
      pipeline::ParseAssembly("[[body]]\nname = \"b\"\npolygon = \"rect.csv\"\nmass_kg = 1\n", dir + "/a.toml"));
  ASSERT_TRUE(rect && poly);
  EXPECT_NEAR(poly->alpha, rect->alpha, 1e-12);
  EXPECT_NEAR(poly->p, rect->p, 1e-12);
  EXPECT_NEAR(poly->mu, rect->mu, 1e-12);
  try {
    pipeline::EquivalentBlock(
        pipeline::ParseAssembly("[[body]]\nname = \"b\"\npolygon = \"leaning.csv\"\nmass_kg = 1\n", dir + "/a.toml"));
    ADD_FAILURE() << "an asymmetric polygon was taken";
  } catch (const pipeline::OptionError& e) {
    EXPECT_NE(std::string(e.what()).find("key 'body.polygon'"), std::string::npos) << e.what();
  }
}

// The command's usage errors exit 2 naming what is wrong: complex on a
// stack, a block option beside --assembly, a bad file (file and key).
TEST(AssemblyCli, UsageErrorsExit2) {
  const std::string dir = ScratchDir("assembly_usage");
  const std::string stack = kSource + "/data/assemblies/drums3.toml";
  WriteFile(dir + "/bad.toml", "[[body]]\nname = \"b\"\nwidth_m = 0.2\nheight_m = 1.0\n");
  const struct {
    std::vector<std::string> args;
    std::string expected;
  } cases[] = {
      {{"--model", "complex", "--assembly", stack}, "only housner takes a stack"},
      {{"--alpha", "0.2", "--assembly", stack}, "--alpha"},
      {{"--assembly", dir + "/bad.toml"}, "bad.toml:1: key 'body.mass_kg' is missing"},
      {{"--p", "3", "--mu", "0.9"}, "simulate: missing required option --alpha (or --assembly);"},
  };
  for (const auto& c : cases) {
    std::vector<std::string> args = c.args;
    args.insert(args.end(), {"--out", dir + "/x.csv"});
    const CliResult r = RunCli(SimulateArgs(args));
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_NE(r.err.find(c.expected), std::string::npos) << r.err;
  }
}

}  // namespace
}  // namespace rocklab::test
