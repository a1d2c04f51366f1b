// `rocklab sweep --assembly FILE.toml` and sweep-plot of its results: a
// one-body assembly and a frame are their single blocks' sweeps, a stack's
// cell is `simulate --assembly` on that cell's excitation, a nearly
// massless upper body leaves the lower block alone, shards of different
// assemblies are refused, and the fragility figure names which body fell
// first. The row's alpha, p and mu of a stack (pipeline::StackRowParams)
// against closed forms.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <filesystem>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/cancel.h"
#include "common/units.h"
#include "model/block.h"
#include "pipeline/assembly.h"
#include "pipeline/option_error.h"
#include "sweep/sweep.h"
#include "tests/source_paths.h"
#include "tests/sweep/sweep_test_util.h"
#include "tests/tools/run_cli.h"

namespace rocklab::test {
namespace {

using common::kGravity;
using common::kPi;

// A results CSV: its header's names and its rows as text fields.
struct AssemblyResults {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
  std::map<std::string, std::size_t> at;  // column by name
  const std::string& Cell(std::size_t row, const std::string& name) const { return rows.at(row).at(at.at(name)); }
};

std::vector<std::string> SplitFields(const std::string& line) {
  std::vector<std::string> fields;
  std::size_t from = 0;
  for (;;) {
    const std::size_t comma = line.find(',', from);
    fields.push_back(line.substr(from, comma == std::string::npos ? std::string::npos : comma - from));
    if (comma == std::string::npos) return fields;
    from = comma + 1;
  }
}

AssemblyResults ReadAssemblyResults(const std::string& path) {
  AssemblyResults r;
  std::istringstream in(ReadFile(path));
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    if (r.header.empty()) {
      r.header = SplitFields(line);
      for (std::size_t i = 0; i < r.header.size(); ++i) r.at[r.header[i]] = i;
      continue;
    }
    r.rows.push_back(SplitFields(line));
    EXPECT_EQ(r.rows.back().size(), r.header.size()) << line;
  }
  return r;
}

// `v` with `digits` significant digits: 17 reads back as the same double,
// 12 is how a sweep's row prints it.
std::string Digits(double v, int digits) {
  char text[40];
  std::snprintf(text, sizeof text, "%.*g", digits, v);
  return text;
}
std::string Exact17(double v) { return Digits(v, 17); }
std::string Digits12(double v) { return Digits(v, 12); }

// The existing columns of a sweep of blocks (sweep::Header()).
const std::vector<std::string> kBlockColumns = {
    "record", "scale", "pga_g", "alpha", "p", "mu", "model", "peak_theta_over_alpha", "overturned",
    "overturn_time", "impacts", "uplift_time", "peak_time", "block", "alpha_minus", "p_minus", "mu_minus"};

CliResult Sweep(std::vector<std::string> args) {
  args.insert(args.begin(), "sweep");
  return RunCli(args);
}

// A 2 Hz sine of unit amplitude for 2 s (m/s^2), 200 Hz: the scales make it
// rock or overturn the bodies below.
std::string SineRecord(const std::string& dir) {
  const std::string path = dir + "/sine.csv";
  WriteRecord(path, 2.0, 0.005, [](double t) { return std::sin(2 * kPi * 2.0 * t); });
  return path;
}

// Oracle: the single block's sweep (`--alpha --p --mu`, the equivalent
// block's parameters as pipeline::EquivalentBlock gives them, passed with
// 17 digits so they are the same doubles). A one-body assembly and a frame
// (Makris and Vassiliou's equivalent block, docs/models.md) run as that
// block: every existing column of every row is the same text but `block`,
// which names the assembly file; the new columns name the body for an
// overturned row (empty otherwise) and give its peak |theta| = peak
// theta/alpha x alpha for the rows that stayed (the same sample's value:
// 1e-11 relative, the two 12-digit roundings).
TEST(SweepAssembly, OneBodyAndFrameRowsAreTheEquivalentBlocks) {
  const std::string dir = ScratchDir("sweep_assembly_single");
  const std::string record = SineRecord(dir);
  WriteFile(dir + "/column.toml",
            "[[body]]\nname = \"column\"\nwidth_m = 0.2\nheight_m = 0.8\nmass_kg = 50.0\n");
  struct Case {
    std::string toml, model, name, scale;  // a grid from rest or rocking to overturning
  };
  const std::string frame = kSource + "/data/assemblies/portal_frame.toml";
  for (const Case& c : {Case{dir + "/column.toml", "housner", "column", "1:7:4"},
                        Case{frame, "housner", "frame", "1.5:3:4"}, Case{frame, "complex", "frame", "1.5:3:4"}}) {
    SCOPED_TRACE(c.toml + " " + c.model);
    const model::BlockParams b = *pipeline::EquivalentBlock(pipeline::ReadAssembly(c.toml));
    const std::vector<std::string> common = {"--records", record, "--scale", c.scale, "--model", c.model,
                                             "--duration", "4", "--rate", "200", "--threads", "1"};
    std::vector<std::string> by_assembly = common, by_block = common;
    by_assembly.insert(by_assembly.end(), {"--assembly", c.toml, "--out", dir + "/assembly.csv"});
    by_block.insert(by_block.end(),
                    {"--alpha", Exact17(b.alpha), "--p", Exact17(b.p), "--mu", Exact17(b.mu), "--out", dir + "/block.csv"});
    const CliResult ra = Sweep(by_assembly), rb = Sweep(by_block);
    ASSERT_EQ(ra.exit_code, 0) << ra.err;
    ASSERT_EQ(rb.exit_code, 0) << rb.err;
    const AssemblyResults a = ReadAssemblyResults(dir + "/assembly.csv");
    const AssemblyResults s = ReadAssemblyResults(dir + "/block.csv");
    std::vector<std::string> header = kBlockColumns;
    header.insert(header.end(), {"first_overturned_body", "peak_abs_theta_1"});
    EXPECT_EQ(a.header, header);
    EXPECT_EQ(s.header, kBlockColumns);
    ASSERT_EQ(a.rows.size(), 4u);
    ASSERT_EQ(s.rows.size(), 4u);
    int overturned = 0;
    for (std::size_t i = 0; i < a.rows.size(); ++i) {
      for (const std::string& name : kBlockColumns) {
        if (name == "block") continue;
        EXPECT_EQ(a.Cell(i, name), s.Cell(i, name)) << name << ", row " << i;
      }
      EXPECT_EQ(a.Cell(i, "block"), std::filesystem::path(c.toml).filename().string());
      if (a.Cell(i, "overturned") == "1") {
        ++overturned;
        EXPECT_EQ(a.Cell(i, "first_overturned_body"), c.name);
      } else {
        EXPECT_EQ(a.Cell(i, "first_overturned_body"), "");
        const double expected = std::stod(a.Cell(i, "peak_theta_over_alpha")) * b.alpha;
        EXPECT_NEAR(std::stod(a.Cell(i, "peak_abs_theta_1")), expected, 1e-11 * expected);
      }
    }
    // The grid reaches both outcomes, so both branches above were checked.
    EXPECT_GT(overturned, 0);
    EXPECT_LT(overturned, 4);
  }
}

// The options of a stack sweep's cell, and that cell's run by `simulate
// --assembly` on the scaled record written out with 17 digits (the same
// doubles the sweep multiplies).
struct StackCell {
  AssemblyResults sweep;
  std::vector<nlohmann::json> simulate;  // per row
};

StackCell SweepAndSimulateEachCell(const std::string& dir, const std::string& toml, double scale_a, double scale_b,
                                   int scales) {
  StackCell out;
  const std::string record = SineRecord(dir);
  const std::string grid = Exact17(scale_a) + ":" + Exact17(scale_b) + ":" + std::to_string(scales);
  const CliResult r = Sweep({"--records", record, "--scale", grid, "--assembly", toml, "--model", "housner",
                             "--duration", "4", "--rate", "200", "--threads", "1", "--out", dir + "/stack.csv"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  out.sweep = ReadAssemblyResults(dir + "/stack.csv");
  for (int k = 0; k < scales; ++k) {
    const double factor = scales == 1 ? scale_a : scale_a + (scale_b - scale_a) * k / (scales - 1);
    const std::string scaled = dir + "/scaled" + std::to_string(k) + ".csv";
    WriteRecord(scaled, 2.0, 0.005, [factor](double t) { return std::sin(2 * kPi * 2.0 * t) * factor; });
    const CliResult s = RunCli({"simulate", "--assembly", toml, "--model", "housner", "--accel", scaled,
                                "--duration", "4", "--rate", "200", "--out", dir + "/run.csv", "--json"});
    EXPECT_EQ(s.exit_code, 0) << s.err;
    out.simulate.push_back(nlohmann::json::parse(s.out));
  }
  return out;
}

// The time columns of a row against simulate's JSON (null: empty field).
std::string TimeText(const nlohmann::json& v) { return v.is_null() ? "" : Digits12(v.get<double>()); }

// Oracle: `simulate --assembly` on the cell's excitation (the record times
// the cell's factor, written with 17 digits: the doubles the sweep
// computes), the same stack model run (pipeline::RunStackUnder). Its uplift
// time, impact count, overturning (time and body) and each body's peak
// |theta| are the row's to the 12 digits the row prints; peak
// theta/alpha is the bodies' largest peak over the row's alpha, or (pi/2) /
// alpha once overturned.
TEST(SweepAssembly, AStackCellIsSimulateAssemblyOnItsExcitation) {
  const std::string dir = ScratchDir("sweep_assembly_stack");
  const std::string toml = kSource + "/data/assemblies/statue_on_pedestal.toml";
  const StackCell c = SweepAndSimulateEachCell(dir, toml, 3.0, 6.0, 3);
  std::vector<std::string> header = kBlockColumns;
  header.insert(header.end(), {"first_overturned_body", "peak_abs_theta_1", "peak_abs_theta_2"});
  ASSERT_EQ(c.sweep.header, header);
  ASSERT_EQ(c.sweep.rows.size(), 3u);
  const double alpha = std::stod(c.sweep.Cell(0, "alpha"));
  int overturned = 0;
  for (std::size_t i = 0; i < 3; ++i) {
    SCOPED_TRACE("row " + std::to_string(i));
    const nlohmann::json& j = c.simulate[i];
    EXPECT_EQ(c.sweep.Cell(i, "block"), "statue_on_pedestal.toml");
    EXPECT_EQ(c.sweep.Cell(i, "uplift_time"), TimeText(j.at("uplift_time")));
    EXPECT_EQ(c.sweep.Cell(i, "impacts"), std::to_string(j.at("impacts").get<int>()));
    EXPECT_EQ(c.sweep.Cell(i, "overturned"), j.at("overturned").get<bool>() ? "1" : "0");
    EXPECT_EQ(c.sweep.Cell(i, "overturn_time"), TimeText(j.at("overturn_time")));
    EXPECT_EQ(c.sweep.Cell(i, "first_overturned_body"),
              j.at("overturned_body").is_null() ? "" : j.at("overturned_body").get<std::string>());
    double peak = 0.0;
    for (std::size_t k = 0; k < 2; ++k) {
      const double body_peak = j.at("bodies").at(k).at("peak_abs_theta").get<double>();
      EXPECT_EQ(c.sweep.Cell(i, "peak_abs_theta_" + std::to_string(k + 1)), Digits12(body_peak));
      peak = std::max(peak, body_peak);
    }
    const bool fell = j.at("overturned").get<bool>();
    overturned += fell ? 1 : 0;
    EXPECT_NEAR(std::stod(c.sweep.Cell(i, "peak_theta_over_alpha")), (fell ? kPi / 2 : peak) / alpha,
                1e-11 * (kPi / 2) / alpha);
  }
  // The grid goes from rocking (the statue lifts and strikes) to overturning.
  EXPECT_EQ(c.sweep.Cell(0, "overturned"), "0");
  EXPECT_NE(c.sweep.Cell(0, "uplift_time"), "");
  EXPECT_NE(c.sweep.Cell(0, "impacts"), "0");
  EXPECT_GT(overturned, 0);
}

// Oracle: a count of the token's polls. A stack's case looks at the token
// before it and after it, and inside it every 256 output samples
// (model::stack::kCancelPollOutputs), as a block's case: a hook that says
// stop at its third call ends the case inside, at output sample 512 of
// 4001, with Cancelled (polled only around the case, it would have run to
// its end and returned). A hook that never says stop is called 2 +
// floor(4000 / 256) = 17 times and leaves the row as without a token.
TEST(SweepAssembly, AStackCaseStopsInsideWhenCancelled) {
  const std::string dir = ScratchDir("sweep_assembly_cancel");
  sweep::PlanOptions o;
  o.records = {SineRecord(dir)};
  o.assembly = kSource + "/data/assemblies/statue_on_pedestal.toml";
  o.model = "housner";
  o.scale = "3:3:1";  // 0.31 g: the statue rocks, nothing overturns (AStackCellIs...'s first row)
  o.duration_s = 4.0;
  const sweep::Plan plan = sweep::MakePlan(o);
  ASSERT_TRUE(plan.stack());
  int calls = 0;
  const common::CancelToken stop_third([&calls] { return ++calls == 3; });
  EXPECT_THROW(sweep::RunCase(plan, 0, &stop_third), common::Cancelled);
  EXPECT_EQ(calls, 3);
  int polls = 0;
  const common::CancelToken never([&polls] {
    ++polls;
    return false;
  });
  const sweep::Outcome polled = sweep::RunCase(plan, 0, &never);
  ASSERT_FALSE(polled.overturned);
  EXPECT_EQ(polls, 2 + 4000 / 256);
  EXPECT_EQ(sweep::FormatRow(plan, 0, polled), sweep::FormatRow(plan, 0, sweep::RunCase(plan, 0)));
}

// Oracle: docs/models.md's massless upper block (the reference
// integration's check: the lower block's events are those of the lower
// block alone, to 1e-6 s). A stack whose upper body has 1e-10 of the
// lower's mass, squat enough (b/h = 6) that it stays shut on the rocking
// base, is swept beside the lower block alone (`--width 0.3 --height 1`,
// the single block with Housner's coefficient, the stack model's impact
// rule for one body): the same outcome per row, uplift and overturning
// times to 1e-6 s, the lower body named as the one that fell, alpha, p
// and mu to 1e-9 relative (the light body moves them by ~1e-10) and peak
// theta/alpha to 1e-6 relative (two integrators at rtol 1e-10 agree to
// 1e-7 rad, StackRun.OneBodyIsRocklabsHousnerModel). `impacts` counts
// every interface's, and the light body chatters on its base (488 impacts
// against the block's 16 in the first row), so only the base's share is
// bounded: at least the block's.
TEST(SweepAssembly, ANearlyMasslessUpperBodyLeavesTheLowerBlockAlone) {
  const std::string dir = ScratchDir("sweep_assembly_massless");
  const std::string record = SineRecord(dir);
  WriteFile(dir + "/light_top.toml",
            "[[body]]\nname = \"base\"\nwidth_m = 0.3\nheight_m = 1.0\nmass_kg = 200.0\n"
            "[[body]]\nname = \"feather\"\nwidth_m = 0.3\nheight_m = 0.05\nmass_kg = 2e-8\n");
  const std::vector<std::string> common = {"--records", record, "--scale", "3:7:3", "--model", "housner",
                                           "--duration", "4", "--rate", "200", "--threads", "1"};
  std::vector<std::string> stack = common, block = common;
  stack.insert(stack.end(), {"--assembly", dir + "/light_top.toml", "--out", dir + "/stack.csv"});
  block.insert(block.end(), {"--width", "0.3", "--height", "1", "--out", dir + "/block.csv"});
  const CliResult rs = Sweep(stack), rb = Sweep(block);
  ASSERT_EQ(rs.exit_code, 0) << rs.err;
  ASSERT_EQ(rb.exit_code, 0) << rb.err;
  const AssemblyResults a = ReadAssemblyResults(dir + "/stack.csv");
  const AssemblyResults s = ReadAssemblyResults(dir + "/block.csv");
  ASSERT_EQ(a.rows.size(), 3u);
  ASSERT_EQ(s.rows.size(), 3u);
  int overturned = 0;
  for (std::size_t i = 0; i < 3; ++i) {
    SCOPED_TRACE("row " + std::to_string(i));
    for (const char* name : {"alpha", "p", "mu"}) {
      EXPECT_NEAR(std::stod(a.Cell(i, name)), std::stod(s.Cell(i, name)), 1e-9 * std::stod(s.Cell(i, name))) << name;
    }
    ASSERT_EQ(a.Cell(i, "overturned"), s.Cell(i, "overturned"));
    EXPECT_GE(std::stoi(a.Cell(i, "impacts")), std::stoi(s.Cell(i, "impacts")));
    EXPECT_NEAR(std::stod(a.Cell(i, "uplift_time")), std::stod(s.Cell(i, "uplift_time")), 1e-6);
    const double peak = std::stod(s.Cell(i, "peak_theta_over_alpha"));
    EXPECT_NEAR(std::stod(a.Cell(i, "peak_theta_over_alpha")), peak, 1e-6 * peak);
    if (s.Cell(i, "overturned") == "1") {
      ++overturned;
      EXPECT_NEAR(std::stod(a.Cell(i, "overturn_time")), std::stod(s.Cell(i, "overturn_time")), 1e-6);
      EXPECT_EQ(a.Cell(i, "first_overturned_body"), "base");
    }
  }
  EXPECT_EQ(s.Cell(0, "overturned"), "0");
  EXPECT_GT(overturned, 0);
}

// Oracle: the file's reader (pipeline::ReadAssembly) names file, line and
// key; sweep passes its message on with exit 2 (a bad input). The complex
// model on a stack is refused as `simulate --assembly` refuses it, and an
// assembly beside --alpha as any second way of giving the blocks.
TEST(SweepAssembly, BadAssembliesAreRefusedNamingFileAndKey) {
  const std::string dir = ScratchDir("sweep_assembly_bad");
  const std::string record = SineRecord(dir);
  WriteFile(dir + "/bad.toml", "[[body]]\nname = \"a\"\nwidth_m = 0.2\nheight_m = -1\nmass_kg = 5\n");
  const std::vector<std::string> common = {"--records", record, "--model", "housner", "--out", dir + "/x.csv"};
  std::vector<std::string> args = common;
  args.insert(args.end(), {"--assembly", dir + "/bad.toml"});
  CliResult r = Sweep(args);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find(dir + "/bad.toml:4"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("height_m"), std::string::npos) << r.err;

  args = {"--records", record, "--model", "complex", "--out", dir + "/x.csv", "--assembly",
          kSource + "/data/assemblies/statue_on_pedestal.toml"};
  r = Sweep(args);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("only housner takes a stack"), std::string::npos) << r.err;

  args = common;
  args.insert(args.end(), {"--assembly", kSource + "/data/assemblies/portal_frame.toml", "--alpha", "0.2", "--p", "3"});
  r = Sweep(args);
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("give the blocks one way"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir + "/x.csv"));
}

// Oracle: the unsharded file, and the definition. Shards of a stack's
// sweep (CSV and HDF5, mixed) merge into the whole sweep's bytes, the
// assembly's columns included; a shard of another assembly file (a copy
// with a comment added: the same key columns and rows, so only the
// definition's size and hash tell) is refused naming the field `assembly`
// and both files, and so is --resume of the file with another assembly.
TEST(SweepAssembly, ShardsOfOneAssemblyMergeAndOfAnotherAreRefused) {
  const std::string dir = ScratchDir("sweep_assembly_merge");
  const std::string record = SineRecord(dir);
  const std::string toml = kSource + "/data/assemblies/statue_on_pedestal.toml";
  // The same stack with every key kept but a comment: another file, the same rows.
  WriteFile(dir + "/statue_on_pedestal.toml", ReadFile(toml) + "# another copy\n");
  const std::vector<std::string> common = {"--records", record, "--scale", "2:6:3", "--model", "housner",
                                           "--duration", "3", "--rate", "100", "--threads", "1"};
  const auto with = [&common](std::vector<std::string> more) {
    std::vector<std::string> a = common;
    a.insert(a.end(), more.begin(), more.end());
    return Sweep(a);
  };
  CliResult r = with({"--assembly", toml, "--out", dir + "/whole.csv"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = with({"--assembly", toml, "--shard", "0/2", "--out", dir + "/part0.h5"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = with({"--assembly", toml, "--shard", "1/2", "--out", dir + "/part1.csv"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = with({"--assembly", toml, "--merge", dir + "/part1.csv", dir + "/part0.h5", "--out", dir + "/merged.csv"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(WithoutProvenanceLines(ReadFile(dir + "/merged.csv")), WithoutProvenanceLines(ReadFile(dir + "/whole.csv")));
  EXPECT_NE(ReadFile(dir + "/whole.csv").find("\n# assembly: statue_on_pedestal.toml "), std::string::npos);

  // --resume of the whole file with another assembly: refused by the same field.
  r = with({"--assembly", kSource + "/data/assemblies/drums3.toml", "--resume", "--out", dir + "/whole.csv"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("its sweep ran with assembly 'statue_on_pedestal.toml "), std::string::npos) << r.err;

  r = with({"--assembly", dir + "/statue_on_pedestal.toml", "--shard", "1/2", "--out", dir + "/other1.csv"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = with({"--assembly", toml, "--merge", dir + "/part0.h5", dir + "/other1.csv", "--out", dir + "/mixed.csv"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find(dir + "/other1.csv and " + dir + "/part0.h5 are shards of different sweeps: assembly "),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir + "/mixed.csv"));
}

#ifdef ROCKLAB_MPIRUN
// Oracle: the threaded run's bytes. Two MPI ranks carry an assembly's
// outcome (the first body to fall and the peaks per body) to rank 0 on
// the wire and write the threaded file (the environment of
// CliSweep.MpiRanksWriteTheThreadedFile, which says why).
TEST(SweepAssembly, MpiRanksWriteTheThreadedStackFile) {
  const std::string dir = ScratchDir("sweep_assembly_mpi");
  const std::string record = SineRecord(dir);
  const std::string bin = ROCKLAB_BINARY;
  const std::string args = " sweep --records " + record + " --scale 3:6:4 --assembly " + kSource +
                           "/data/assemblies/statue_on_pedestal.toml --model housner --duration 3 --rate 100";
  const CliResult threads = Sweep({"--records", record, "--scale", "3:6:4", "--assembly",
                                   kSource + "/data/assemblies/statue_on_pedestal.toml", "--model", "housner",
                                   "--duration", "3", "--rate", "100", "--threads", "2", "--out",
                                   dir + "/threads.csv"});
  ASSERT_EQ(threads.exit_code, 0) << threads.err;
  const std::string env = "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_btl=self,vader "
                          "OMPI_MCA_oob_tcp_if_include=lo OMPI_MCA_btl_tcp_if_include=lo OMPI_MCA_pml=ob1 "
                          "OMPI_MCA_memory=^patcher ASAN_OPTIONS=\"${ASAN_OPTIONS:-}:detect_leaks=0\" ";
  const int status = std::system((env + ROCKLAB_MPIRUN + std::string(" -np 2 --oversubscribe ") + bin + args +
                                  " --out " + dir + "/mpi.csv > " + dir + "/mpi.out 2> " + dir + "/mpi.err")
                                     .c_str());
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << ReadFile(dir + "/mpi.err");
  EXPECT_NE(ReadFile(dir + "/mpi.out").find("x 2 ranks"), std::string::npos) << ReadFile(dir + "/mpi.out");
  const std::string whole = ReadFile(dir + "/threads.csv");
  EXPECT_NE(whole.find(",statue,"), std::string::npos);  // a row that names the body carried the wire
  EXPECT_EQ(WithoutProvenanceLines(ReadFile(dir + "/mpi.csv")), WithoutProvenanceLines(whole));
}
#endif

// Oracle: a hand count of the rows. sweep-plot of a stack's sweep prints
// and draws which body overturned first: the count per body (the rows'
// first_overturned_body), a curve per body in the fragility figure, and
// the same counts in --json.
TEST(SweepAssembly, SweepPlotNamesTheBodyThatFellFirst) {
  const std::string dir = ScratchDir("sweep_assembly_plot");
  const std::string record = SineRecord(dir);
  const std::string toml = kSource + "/data/assemblies/statue_on_pedestal.toml";
  CliResult r = Sweep({"--records", record, "--scale", "1:7:7", "--assembly", toml, "--model", "housner",
                       "--duration", "3", "--rate", "100", "--out", dir + "/stack.csv"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const AssemblyResults a = ReadAssemblyResults(dir + "/stack.csv");
  std::map<std::string, int> fell;
  for (std::size_t i = 0; i < a.rows.size(); ++i) {
    if (a.Cell(i, "overturned") == "1") ++fell[a.Cell(i, "first_overturned_body")];
  }
  ASSERT_FALSE(fell.empty());
  r = RunCli({"sweep-plot", dir + "/stack.csv", "--out-dir", dir + "/figs"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const auto& [body, n] : fell) {
    EXPECT_NE(r.out.find(body + " in " + std::to_string(n) + " cases"), std::string::npos) << r.out;
  }
  std::string figure;
  for (const auto& entry : std::filesystem::directory_iterator(dir + "/figs")) {
    if (entry.path().filename().string().rfind("fragility_", 0) == 0) figure = ReadFile(entry.path().string());
  }
  ASSERT_FALSE(figure.empty());
  for (const auto& [body, n] : fell) EXPECT_NE(figure.find(body + " overturned first"), std::string::npos) << body;
  r = RunCli({"sweep-plot", dir + "/stack.csv", "--out-dir", dir + "/figs", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  for (const auto& [body, n] : fell) EXPECT_EQ(j.at("fragility").at(0).at("first_overturned").at(body), n);
}

// Oracle: the closed forms of docs/sweep.md, "Assemblies". (1) The issue's
// uplift from rest of two rectangles, a/g = min(b2/h2, (m1 + m2) b1 / (m1
// h1 + m2 (2 h1 + h2))), as the row's tan(alpha), to 1e-12, for a stack
// whose statue lifts first and one whose base does. (2) Two rectangles of
// one width and density glued are one rectangle of their summed height:
// their p and mu are `params`' of it (model::RectangleBlock: p^2 = 3 g /
// (4 R), mu = 1 - 1.5 sin^2 alpha), to 1e-12.
TEST(SweepAssembly, AStacksRowParametersAreItsUpliftAndItsGluedBody) {
  const auto stack = [](double w1, double h1, double m1, double w2, double h2, double m2) {
    char text[400];
    std::snprintf(text, sizeof text,
                  "[[body]]\nname = \"one\"\nwidth_m = %.17g\nheight_m = %.17g\nmass_kg = %.17g\n"
                  "[[body]]\nname = \"two\"\nwidth_m = %.17g\nheight_m = %.17g\nmass_kg = %.17g\n",
                  w1, h1, m1, w2, h2, m2);
    return pipeline::StackRowParams(pipeline::ParseAssembly(text, "stack.toml"));
  };
  struct Geometry {
    double w1, h1, m1, w2, h2, m2;
  };
  for (const Geometry& g : {Geometry{0.5, 0.4, 240, 0.2, 0.8, 86.4}, Geometry{0.3, 1.2, 100, 0.25, 0.3, 400}}) {
    const double b1 = g.w1 / 2, h1 = g.h1 / 2, b2 = g.w2 / 2, h2 = g.h2 / 2;
    const double up = std::min(b2 / h2, (g.m1 + g.m2) * b1 / (g.m1 * h1 + g.m2 * (2 * h1 + h2)));
    EXPECT_NEAR(std::tan(stack(g.w1, g.h1, g.m1, g.w2, g.h2, g.m2).alpha), up, 1e-12 * up);
  }
  // One width, one density (mass per height 100 kg/m).
  const model::BlockParams glued = stack(0.4, 1.0, 100.0, 0.4, 0.5, 50.0);
  const model::BlockGeometry whole = model::RectangleBlock(0.4, 1.5);
  EXPECT_NEAR(glued.alpha, whole.alpha, 1e-12);
  EXPECT_NEAR(glued.p, whole.p, 1e-12 * whole.p);
  EXPECT_NEAR(glued.mu, 1 - 1.5 * std::pow(std::sin(whole.alpha), 2), 1e-12);
  EXPECT_THROW(pipeline::StackRowParams(pipeline::ParseAssembly(
                   "[[body]]\nname = \"a\"\nwidth_m = 0.2\nheight_m = 0.8\nmass_kg = 5\n", "one.toml")),
               pipeline::OptionError);
}

}  // namespace
}  // namespace rocklab::test
