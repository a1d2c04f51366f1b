// `rocklab sweep` and `rocklab sweep-plot` as a user runs them: the
// one-cosine pulse threshold of the literature bracketed by a sweep's grid,
// a half-sine threshold of a sweep against a bisection of `rocklab
// simulate`, MPI ranks against threads, shards merged against the whole.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <nlohmann/json.hpp>

#include "common/units.h"
#include "tests/sweep/oracle/oracle.h"
#include "tests/sweep/sweep_test_util.h"
#include "tests/tools/run_cli.h"

namespace rocklab::test {
namespace {

using common::kGravity;
using common::kPi;

struct Row {
  double pga_g{};
  bool overturned{};
  double peak{};
};

// The rows of a results file, by the header's names.
std::vector<Row> ReadRows(const std::string& path) {
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line) && !line.empty() && line[0] == '#') {
  }  // the sweep's definition, then the header
  std::map<std::string, int> col;
  {
    std::stringstream h(line);
    std::string name;
    for (int i = 0; std::getline(h, name, ','); ++i) col[name] = i;
  }
  std::vector<Row> rows;
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::stringstream s(line);
    std::string x;
    while (std::getline(s, x, ',')) f.push_back(x);
    Row r;
    r.pga_g = std::stod(f.at(col.at("pga_g")));
    r.overturned = f.at(col.at("overturned")) == "1";
    r.peak = std::stod(f.at(col.at("peak_theta_over_alpha")));
    rows.push_back(r);
  }
  return rows;
}

// The grid's bracket of the threshold: the last safe and the first
// overturned PGA, after checking there is exactly one change along the grid.
std::pair<double, double> Bracket(const std::vector<Row>& rows) {
  int changes = 0;
  std::pair<double, double> b{NAN, NAN};
  for (std::size_t k = 1; k < rows.size(); ++k) {
    if (rows[k].overturned != rows[k - 1].overturned) {
      ++changes;
      b = {rows[k - 1].pga_g, rows[k].pga_g};
      EXPECT_TRUE(rows[k].overturned) << "safe again above " << rows[k - 1].pga_g << " g";
    }
  }
  EXPECT_EQ(changes, 1) << "the grid must cross the threshold once";
  return b;
}

// Makris & Konstantinidis (2003), "The rocking spectrum and the limitations
// of practical design methodologies", EESD 32: a block with p = 2 rad/s and
// alpha = 15 deg under the one-cosine pulse u_g''(t) = a_p cos(omega_p t),
// 0 <= t <= T_p = 2 s (omega_p = pi rad/s), zero outside (the pulse starts
// with its full a_p: the block lifts at t = 0), with the coefficient of
// restitution at Housner's maximum value, angular velocity ratio
// 1 - 1.5 sin^2 alpha (energy ratio its square), overturns for a_p above
// 0.315034 g.
// Oracle: that printed threshold, bracketed by the sweep's grid of target
// PGAs 1e-3 g apart (the record is the pulse sampled every 1 ms, linear
// between samples: its largest departure from the cosine is pi^2 dt^2 / 8
// = 1.2e-6 of a_p, far below the grid's 3e-3 relative spacing). Measured:
// safe at 0.31503 g, overturned at 0.31504 g (a grid 1e-5 g apart). The
// grid stops at 0.320 g because overturning is not monotonic in a_p here:
// the block overturns from 0.316 to 0.328 g and survives again at 0.329 and
// 0.330 g (the safe region above the minimum overturning acceleration that
// Makris and co-workers' overturning spectra show).
TEST(CliSweep, OneCosinePulseThresholdOfMakrisAndKonstantinidis) {
  const std::string dir = ScratchDir("sweep_cosine");
  WriteRecord(dir + "/cosine.csv", 2.0, 0.001, [](double t) { return std::cos(kPi * t); });
  const CliResult r = RunCli({"sweep", "--records", dir + "/cosine.csv", "--pga-g", "--scale", "0.300:0.320:21",
                              "--alpha", "0.26179938779914941", "--p", "2", "--model", "housner", "--duration", "12",
                              "--rate", "200", "--out", dir + "/cosine_results.csv"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto [safe, over] = Bracket(ReadRows(dir + "/cosine_results.csv"));
  std::printf("one-cosine pulse: safe at %.4f g, overturned at %.4f g (literature 0.315034 g)\n", safe, over);
  EXPECT_LE(over - safe, 1e-3 + 1e-12);
  EXPECT_LE(safe, 0.315034);
  EXPECT_GE(over, 0.315034);
}

// Oracle: the threshold of a half-sine pulse a_p sin(pi t / 0.5 s) on
// [0, 0.5 s] for a block alpha = 0.2 rad, p = 3 rad/s, mu = 0.9, found by
// bisecting `rocklab simulate --accel` (the record written at each a_p;
// 22 halvings of [0.2, 3] g, to 1e-6 g), lies in the bracket of a sweep of
// the same pulse on a grid 5e-4 g apart: they agree within 1e-3 g.
TEST(CliSweep, HalfSineThresholdAgreesWithBisectingSimulate) {
  const std::string dir = ScratchDir("sweep_halfsine");
  const double tp = 0.5;
  auto pulse = [tp](double a) { return [a, tp](double t) { return a * std::sin(kPi * t / tp); }; };
  auto overturns = [&](double a_g) {
    WriteRecord(dir + "/bisect.csv", tp, 0.001, pulse(a_g * kGravity));
    const CliResult s = RunCli({"simulate", "--model", "housner", "--alpha", "0.2", "--p", "3", "--mu", "0.9",
                                "--accel", dir + "/bisect.csv", "--duration", "10", "--rate", "200", "--out",
                                dir + "/bisect_theta.csv", "--json"});
    EXPECT_EQ(s.exit_code, 0) << s.err;
    return nlohmann::json::parse(s.out).at("overturned").get<bool>();
  };
  double lo = 0.2, hi = 3.0;
  ASSERT_FALSE(overturns(lo));
  ASSERT_TRUE(overturns(hi));
  for (int k = 0; k < 22; ++k) {
    const double mid = 0.5 * (lo + hi);
    (overturns(mid) ? hi : lo) = mid;
  }
  const double bisected = 0.5 * (lo + hi);

  WriteRecord(dir + "/halfsine.csv", tp, 0.001, pulse(1.0));
  const CliResult r = RunCli({"sweep", "--records", dir + "/halfsine.csv", "--pga-g", "--scale",
                              "0.365:0.385:41", "--alpha", "0.2", "--p", "3", "--mu", "0.9", "--model", "housner",
                              "--duration", "10", "--rate", "200", "--out", dir + "/halfsine_results.csv"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto [safe, over] = Bracket(ReadRows(dir + "/halfsine_results.csv"));
  std::printf("half-sine pulse: bisection of simulate %.6f g, sweep bracket [%.4f, %.4f] g\n", bisected, safe, over);
  EXPECT_LE(safe, bisected);
  EXPECT_GE(over, bisected);
  EXPECT_LE(std::abs(0.5 * (safe + over) - bisected), 1e-3);
}

std::string SmallSweep(const std::string& dir) {
  WriteRecord(dir + "/pulse.csv", 0.6, 0.002, [](double t) { return 2.5 * std::sin(kPi * t / 0.6); });
  WriteFilteredNoise(dir + "/noise.csv", 11, 2.0, 0.005, 4.0, 2.5);
  return "--records " + dir + "/pulse.csv " + dir + "/noise.csv --pga-g --scale 0.15:0.45:7 --alpha 0.2 0.25 "
         "--p 2.5 3.5 --model housner --duration 3 --rate 200";
}

int Shell(const std::string& command) {
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string Slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Oracle: the whole sweep's bytes. Shards 0/3..2/3 merged by `sweep
// --merge`, and by the documented shell recipe (paste the shards' rows
// round-robin), give them back; --out x.h5 writes an HDF5 file (its
// content: sweep_test's Hdf5HoldsTheCsvRows).
TEST(CliSweep, ShardsMergedGiveTheWhole) {
  const std::string dir = ScratchDir("sweep_shards");
  const std::string bin = ROCKLAB_BINARY, args = SmallSweep(dir);
  ASSERT_EQ(Shell(bin + " sweep " + args + " --threads 2 --out " + dir + "/whole.csv > /dev/null"), 0);
  for (int i = 0; i < 3; ++i) {
    ASSERT_EQ(Shell(bin + " sweep " + args + " --shard " + std::to_string(i) + "/3 --out " + dir + "/part" +
                    std::to_string(i) + ".csv > /dev/null"),
              0);
  }
  ASSERT_EQ(Shell(bin + " sweep " + args + " --merge " + dir + "/part2.csv " + dir + "/part0.csv " + dir +
                  "/part1.csv --out " + dir + "/merged.csv > /dev/null"),
            0);
  const std::string whole = Slurp(dir + "/whole.csv");
  ASSERT_GT(whole.size(), 100u);
  // Byte for byte but the provenance lines (each run's own command and time).
  EXPECT_EQ(WithoutProvenanceLines(Slurp(dir + "/merged.csv")), WithoutProvenanceLines(whole));
  const std::string p = dir + "/part";
  // docs/sweep.md's recipe: the definition and header of shard 0, then the rows round-robin.
  const std::string rows = " <(sed \"0,/^record,/d\" " + p;
  ASSERT_EQ(Shell("bash -c '{ sed \"/^record,/q\" " + p + "0.csv; paste -d \"\\n\"" + rows + "0.csv)" + rows +
                  "1.csv)" + rows + "2.csv) | sed \"/^$/d\"; } > " + dir + "/pasted.csv'"),
            0);
  EXPECT_EQ(WithoutProvenanceLines(Slurp(dir + "/pasted.csv")), WithoutProvenanceLines(whole));

  const CliResult h5 = RunCli({"sweep", "--records", dir + "/pulse.csv", "--alpha", "0.2", "--p", "3", "--model",
                               "housner", "--out", dir + "/x.h5"});
  EXPECT_EQ(h5.exit_code, 0) << h5.err;
  EXPECT_TRUE(std::filesystem::exists(dir + "/x.h5"));
}

// Oracle: the shards' own options. A shard run at --duration 4 among
// shards run at 3 s (the same key columns) stops the merge with exit 2 (a
// bad input, as every refused shard), naming the field, both files and
// values; so does `--merge .` and a shard that is also --out, which keeps
// its bytes.
TEST(CliSweep, MergeRefusesShardsOfAnotherDurationADirectoryAndItsOutput) {
  const std::string dir = ScratchDir("sweep_merge_refusals");
  const std::string bin = ROCKLAB_BINARY, args = SmallSweep(dir);
  for (int i = 0; i < 3; ++i) {
    std::string shard_args = args;
    if (i == 2) shard_args.replace(shard_args.find("--duration 3"), 12, "--duration 4");
    ASSERT_EQ(Shell(bin + " sweep " + shard_args + " --shard " + std::to_string(i) + "/3 --out " + dir +
                    "/part" + std::to_string(i) + ".csv > /dev/null"),
              0);
  }
  std::vector<std::string> merge = {"sweep"};
  std::stringstream words(args);
  for (std::string w; words >> w;) merge.push_back(w);
  const std::vector<std::string> parts = {dir + "/part0.csv", dir + "/part1.csv", dir + "/part2.csv"};
  const auto run = [&](const std::vector<std::string>& files, const std::string& out) {
    std::vector<std::string> a = merge;
    a.push_back("--merge");
    a.insert(a.end(), files.begin(), files.end());
    a.push_back("--out");
    a.push_back(out);
    return RunCli(a);
  };
  CliResult r = run(parts, dir + "/merged.csv");
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find(parts[2] + " and " + parts[0] + " are shards of different sweeps: duration_s '4' in " +
                       parts[2] + ", '3' in " + parts[0]),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir + "/merged.csv"));
  r = run({parts[0], parts[1], "."}, dir + "/merged.csv");
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("--merge: '.' is a directory"), std::string::npos) << r.err;
  const std::string before = Slurp(parts[0]);
  r = run({parts[0], parts[1]}, parts[0]);
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("is also --out"), std::string::npos) << r.err;
  EXPECT_EQ(Slurp(parts[0]), before);
}

#ifdef ROCKLAB_MPIRUN
// Oracle: the threaded run's bytes. Two MPI ranks on this machine (shared
// memory between them, the runtime's own TCP on loopback only) write the
// same file through rank 0. Under the sanitizer pass, OpenMPI's own
// allocations at MPI_Init that it never frees would fail LeakSanitizer,
// and its memory patcher hooks the allocator ASan owns: both are off for
// the ranks of this test only (the other sweep tests keep leak checks).
TEST(CliSweep, MpiRanksWriteTheThreadedFile) {
  const std::string dir = ScratchDir("sweep_mpi");
  const std::string bin = ROCKLAB_BINARY, args = SmallSweep(dir);
  ASSERT_EQ(Shell(bin + " sweep " + args + " --threads 2 --out " + dir + "/threads.csv > /dev/null"), 0);
  const std::string env = "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_btl=self,vader "
                          "OMPI_MCA_oob_tcp_if_include=lo OMPI_MCA_btl_tcp_if_include=lo OMPI_MCA_pml=ob1 "
                          "OMPI_MCA_memory=^patcher ASAN_OPTIONS=\"${ASAN_OPTIONS:-}:detect_leaks=0\" ";
  const int code = Shell(env + ROCKLAB_MPIRUN + std::string(" -np 2 --oversubscribe ") + bin + " sweep " + args +
                         " --out " + dir + "/mpi.csv > " + dir + "/mpi.out 2> " + dir + "/mpi.err");
  ASSERT_EQ(code, 0) << Slurp(dir + "/mpi.err");
  EXPECT_NE(Slurp(dir + "/mpi.out").find("x 2 ranks"), std::string::npos) << Slurp(dir + "/mpi.out");
  EXPECT_EQ(WithoutProvenanceLines(Slurp(dir + "/mpi.csv")),
            WithoutProvenanceLines(Slurp(dir + "/threads.csv")));
}
#endif

// Oracle: sweep-plot on a sweep's results writes the figures it lists and
// fragility.csv, and prints each block's fit (or why there is none).
TEST(CliSweep, SweepPlotDrawsAndFits) {
  const std::string dir = ScratchDir("sweep_plot");
  const std::string bin = ROCKLAB_BINARY, args = SmallSweep(dir);
  ASSERT_EQ(Shell(bin + " sweep " + args + " --out " + dir + "/results.csv > /dev/null"), 0);
  const CliResult r = RunCli({"sweep-plot", dir + "/results.csv", "--out-dir", dir + "/figs"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // Named by what they show; two p make no spectrum against p.
  for (const char* f : {"fragility.csv", "fragility_housner_alpha0.2_p2.5.svg",
                        "spectrum_vs_pga_housner_alpha0.2_p2.5.svg", "overturn_map_housner_alpha0.2.svg",
                        "overturn_map_housner_alpha0.25.svg"}) {
    EXPECT_TRUE(std::filesystem::exists(dir + "/figs/" + f)) << f << "\n" << r.out;
  }
  EXPECT_NE(r.out.find("housner alpha 0.2 rad, p 2.5 rad/s"), std::string::npos) << r.out;
  const CliResult bad = RunCli({"sweep-plot", dir + "/pulse.csv"});
  EXPECT_EQ(bad.exit_code, 2);
  EXPECT_NE(bad.err.find("pulse.csv:1:"), std::string::npos) << bad.err;
}

// Oracle: scipy's maximum-likelihood fit of the committed outcomes
// (tests/sweep/oracle/, FragilityOracle.MatchesScipysMaximumLikelihoodFit
// for the tolerance: 1e-6 relative, scipy is within 2e-8 of the maximiser).
// The outcomes are written as a sweep's results (one row per case), so
// what `sweep-plot` reads, groups, fits and writes to fragility.csv (%.9g)
// and prints (%.4g) is checked against numbers made outside rocklab.
TEST(CliSweep, SweepPlotFitMatchesScipy) {
  const test::FragilityOracle o = test::ReadFragilityOracle();
  const std::string dir = ScratchDir("sweep_plot_oracle");
  {
    std::ofstream f(dir + "/results.csv");
    f << "record,scale,pga_g,alpha,p,mu,model,peak_theta_over_alpha,overturned\n";
    int k = 0;
    for (const auto& pt : o.points) {
      for (int i = 0; i < static_cast<int>(pt.trials); ++i) {
        f << "r" << ++k << ",1," << pt.x << ",0.2,2.5,0.9,housner," << (i < pt.overturned ? "1" : "0.5") << ","
          << (i < pt.overturned ? 1 : 0) << "\n";
      }
    }
  }
  const CliResult r = RunCli({"sweep-plot", dir + "/results.csv", "--out-dir", dir + "/figs"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::ifstream table(dir + "/figs/fragility.csv");
  std::string header, row;
  ASSERT_TRUE(std::getline(table, header) && std::getline(table, row));
  EXPECT_EQ(header, "model,alpha,p,mu,rows,overturned,status,median_pga_g,beta,safe_below_g,overturned_above_g,"
                    "pga_min_g,pga_max_g,median_low_g,median_high_g,caveat");
  std::vector<std::string> cells;
  std::stringstream ss(row);
  for (std::string c; std::getline(ss, c, ',');) cells.push_back(c);
  ASSERT_GE(cells.size(), 9u) << row;
  EXPECT_EQ(cells[4], "80") << row;   // cases: the sum of the data set's trials
  EXPECT_EQ(cells[5], "43") << row;   // overturned
  EXPECT_EQ(cells[6], "fitted") << row;
  EXPECT_NEAR(std::stod(cells[7]), o.median_g, 1e-6 * o.median_g) << row;
  EXPECT_NEAR(std::stod(cells[8]), o.beta, 1e-6 * o.beta) << row;
  char printed[80];
  std::snprintf(printed, sizeof printed, "median %.4g g, dispersion %.4g", o.median_g, o.beta);
  EXPECT_NE(r.out.find(printed), std::string::npos) << printed << "\n" << r.out;
}

}  // namespace
}  // namespace rocklab::test
