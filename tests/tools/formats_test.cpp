// Every command reads every format of the data it reads (tools/formats.h):
// the test walks the matrix reader x format. For each reader (a command's
// option) and each format of its kind, it writes or makes a file of that
// format, runs the command on it (oracle: exit 0 and nothing on stderr
// naming the file as unreadable), and checks that `rocklab help COMMAND`
// names the format. A new format in kFormats, or a new reader in
// kReaders, fails here until a sample maker and a command line exist for it
// and the command reads it.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "sweep/plot.h"
#include "tests/sweep/sweep_test_util.h"
#include "tests/tools/run_cli.h"
#include "tools/formats.h"

namespace rocklab::test {
namespace {

using tools::DataFormat;
using tools::DataKind;
using tools::DataReader;

std::string Join(const std::vector<std::string>& args) {
  std::string out;
  for (const std::string& a : args) out += a + " ";
  return out;
}

// A ground-motion record small enough to count as free rocking for `fit`
// (peak 0.01 m/s^2 < model::kForcedTableAccel = 0.05 m/s^2) and non-zero for
// `sweep` (which refuses a record of PGA 0): 2 s of a 2 Hz sine at 100 Hz.
constexpr double kPeak_mps2 = 0.01, kDt_s = 0.01;
constexpr int kSamples = 200;
double Accel(int k) { return kPeak_mps2 * std::sin(2 * M_PI * 2.0 * k * kDt_s); }

std::string AccelCsv(const std::string& dir) {
  std::string text = "time,accel\n";
  char buf[64];
  for (int k = 0; k < kSamples; ++k) {
    std::snprintf(buf, sizeof buf, "%.4f,%.9g\n", k * kDt_s, Accel(k));
    text += buf;
  }
  WriteFile(dir + "/record.csv", text);
  return dir + "/record.csv";
}

std::string PeerAt2(const std::string& dir) {
  std::string text =
      "PEER NGA STRONG MOTION DATABASE RECORD\nSYNTHETIC, 2 HZ SINE\n"
      "ACCELERATION TIME SERIES IN UNITS OF G\nNPTS=   200, DT=   .0100 SEC\n";
  char buf[32];
  for (int k = 0; k < kSamples; ++k) {
    std::snprintf(buf, sizeof buf, "%15.7E", Accel(k) / 9.81);
    text += buf;
    text += (k % 5 == 4) ? "\n" : "";
  }
  WriteFile(dir + "/record.AT2", text);
  return dir + "/record.AT2";
}

// A sweep's results in the format `extension` selects, made by rocklab sweep.
std::string SweepResults(const std::string& dir, const std::string& extension) {
  const std::string record = AccelCsv(dir);
  const std::string out = dir + "/results" + extension;
  const CliResult r = RunCli({"sweep", "--records", record, "--alpha", "0.2", "--p", "2", "3", "--model",
                              "housner", "--scale", "0.1:1:4", "--pga-g", "--duration", "3", "--out", out,
                              "--threads", "1"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return out;
}

// Makes a sample of each format into `dir`, by the format's name.
const std::map<std::string, std::function<std::string(const std::string&)>>& SampleMakers() {
  static const std::map<std::string, std::function<std::string(const std::string&)>> makers = {
      {"time,accel CSV", AccelCsv},
      {"PEER NGA .AT2", PeerAt2},
      {"CSV", [](const std::string& dir) { return SweepResults(dir, ".csv"); }},
      {"HDF5", [](const std::string& dir) { return SweepResults(dir, ".h5"); }},
  };
  return makers;
}

// The command line of each reader, FILE standing for the sample, DIR for
// the scratch folder.
std::vector<std::string> CommandLine(const DataReader& reader, const std::string& file, const std::string& dir) {
  const std::string command = reader.command, option = reader.option;
  if (command == "simulate" && option == "--accel") {
    return {"simulate", "--alpha", "0.2", "--p", "3", "--mu", "0.9", "--accel", file, "--rate", "50",
            "--out", dir + "/theta.csv"};
  }
  if (command == "synth" && option == "--accel") {
    return {"synth", "--rig", std::string(ROCKLAB_SOURCE_DIR) + "/data/rigs/lab_rig.toml", "--alpha", "0.2",
            "--p", "3", "--mu", "0.9", "--accel", file, "--duration", "0.5", "--rate", "1000",
            "--out", dir + "/raw.csv", "--truth", dir + "/truth.csv"};
  }
  if (command == "fit" && option == "--accel") {
    // A free-rocking record to fit (block 1 of the paper's Table 1).
    const CliResult sim = RunCli({"simulate", "--alpha", "0.242", "--p", "3.78", "--mu", "0.914", "--theta0",
                                  "0.1", "--duration", "4", "--rate", "200", "--out", dir + "/free.csv"});
    EXPECT_EQ(sim.exit_code, 0) << sim.err;
    return {"fit", "--input", dir + "/free.csv", "--accel", file, "--width", "0.247", "--height", "1.0",
            "--quiet", "--json"};
  }
  if (command == "sweep" && option == "--records") {
    return {"sweep", "--records", file, "--alpha", "0.2", "--p", "3", "--model", "housner", "--duration", "1",
            "--out", dir + "/sweep.csv", "--threads", "1"};
  }
  if (command == "info" && option == "input") return {"info", file};
  if (command == "sweep-plot" && option == "results") return {"sweep-plot", file, "--out-dir", dir + "/figures"};
  if (command == "sweep" && option == "--merge") {
    // The sample is the whole sweep: one shard of itself (SweepResults' options).
    return {"sweep", "--records", dir + "/record.csv", "--alpha", "0.2", "--p", "2", "3", "--model", "housner",
            "--scale", "0.1:1:4", "--pga-g", "--duration", "3", "--merge", file, "--out", dir + "/merged.h5"};
  }
  return {};
}

std::string KindName(DataKind kind) {
  switch (kind) {
    case DataKind::kGroundMotion: return "ground motion";
    case DataKind::kSweepResults: return "sweep results";
  }
  return "?";
}

TEST(Formats, EveryReaderReadsEveryFormatOfItsKind) {
  int pairs = 0;
  for (const DataReader& reader : tools::kReaders) {
    for (const DataFormat& format : tools::kFormats) {
      if (format.kind != reader.kind) continue;
      SCOPED_TRACE(std::string(reader.command) + " " + reader.option + " x " + KindName(format.kind) + " " +
                   format.name);
      const std::string dir = ScratchDir(std::string("formats_") + reader.command + "_" + std::to_string(pairs));
      const auto maker = SampleMakers().find(format.name);
      ASSERT_NE(maker, SampleMakers().end()) << "no sample maker for the format: add one to SampleMakers()";
      const std::string file = maker->second(dir);
      const std::vector<std::string> args = CommandLine(reader, file, dir);
      ASSERT_FALSE(args.empty()) << "no command line for the reader: add one to CommandLine()";
      const CliResult r = RunCli(args);
      EXPECT_EQ(r.exit_code, 0) << Join(args) << "\n" << r.err;
      ++pairs;
    }
  }
  // 5 ground-motion readers x 2 formats + 3 results readers x 2 formats.
  EXPECT_GE(pairs, 16);
}

TEST(Formats, EveryReadersHelpNamesEveryFormat) {
  for (const DataReader& reader : tools::kReaders) {
    const CliResult r = RunCli({"help", reader.command});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    // The help line of the option (CLI11 prints a positional by its name).
    const std::size_t at = r.out.find(std::string("  ") + reader.option + " ");
    ASSERT_NE(at, std::string::npos) << reader.command << " help has no " << reader.option << ":\n" << r.out;
    const std::string line = r.out.substr(at, r.out.find('\n', at) - at);
    for (const DataFormat& format : tools::kFormats) {
      if (format.kind != reader.kind) continue;
      EXPECT_NE(line.find(format.name), std::string::npos)
          << reader.command << " " << reader.option << " does not name " << format.name << ": " << line;
    }
  }
}

// The info of each sample says what it is.
TEST(Formats, InfoNamesTheKindAndFormat) {
  const std::string dir = ScratchDir("formats_info");
  const struct {
    std::string file, says;
  } cases[] = {{AccelCsv(dir), "ground-motion record (time,accel CSV)"},
               {PeerAt2(dir), "ground-motion record (PEER NGA .AT2)"},
               {SweepResults(dir, ".csv"), "sweep results (CSV)"},
               {SweepResults(dir, ".h5"), "sweep results (HDF5)"}};
  for (const auto& c : cases) {
    const CliResult r = RunCli({"info", c.file});
    ASSERT_EQ(r.exit_code, 0) << r.err;
    EXPECT_NE(r.out.find(c.says), std::string::npos) << r.out;
  }
  // Results with their columns in another order (sweep-plot reads them) and
  // a block label on one row only: info and sweep-plot know them; the
  // label stays on its row (oracle: one fragility row per block, 2 here).
  WriteFile(dir + "/reordered.csv",
            "model,record,scale,pga_g,alpha,p,mu,peak_theta_over_alpha,overturned,block\n"
            "housner,r1,1,0.5,0.2,2,0.9,0.1,0,0.4x2\n"
            "housner,r1,2,1.0,0.2,2,0.9,1,1,\n");
  const CliResult reordered = RunCli({"info", dir + "/reordered.csv"});
  ASSERT_EQ(reordered.exit_code, 0) << reordered.err;
  EXPECT_NE(reordered.out.find("sweep results (CSV)"), std::string::npos) << reordered.out;
  const std::vector<sweep::ResultRow> rows = sweep::ReadResults(dir + "/reordered.csv");
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0].block, "0.4x2");
  EXPECT_EQ(rows[1].block, "-");  // not the row above's
  // Oracle: the AT2 holds kSamples values in g at 0.01 s; its PGA is the
  // largest |value| * 9.81, printed to 6 significant digits.
  const CliResult r = RunCli({"info", "--json", dir + "/record.AT2"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("\"samples\": 200"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("\"kind\": \"ground_motion\""), std::string::npos) << r.out;
}

// The figures and fits of sweep-plot are the same from the CSV and the
// HDF5 results of the same sweep (oracle: fragility.csv byte for byte).
TEST(Formats, SweepPlotGivesTheSameFitsFromCsvAndHdf5) {
  const std::string dir = ScratchDir("formats_same_fits");
  const std::string csv = SweepResults(dir, ".csv"), h5 = SweepResults(dir, ".h5");
  ASSERT_EQ(RunCli({"sweep-plot", csv, "--out-dir", dir + "/from_csv"}).exit_code, 0);
  ASSERT_EQ(RunCli({"sweep-plot", h5, "--out-dir", dir + "/from_h5"}).exit_code, 0);
  EXPECT_EQ(ReadFile(dir + "/from_csv/fragility.csv"), ReadFile(dir + "/from_h5/fragility.csv"));
}

// sweep --merge takes a shard in either format and writes either: the
// HDF5 results merged into a CSV are the CSV of the same sweep byte for
// byte (HDF5 -> CSV is exact), and the CSV merged into an .h5 is read by
// info and sweep-plot as `sweep --out x.h5`'s is (oracle: the same
// fragility.csv as from the CSV).
TEST(Formats, MergeTakesAndWritesEitherFormat) {
  const std::string dir = ScratchDir("formats_merge");
  const std::string csv = SweepResults(dir, ".csv"), h5 = SweepResults(dir, ".h5");
  const std::vector<std::string> sweep = {"sweep", "--records", dir + "/record.csv", "--alpha", "0.2", "--p", "2", "3",
                                          "--model", "housner", "--scale", "0.1:1:4", "--pga-g", "--duration", "3"};
  std::vector<std::string> args = sweep;
  args.insert(args.end(), {"--merge", h5, "--out", dir + "/from_h5.csv"});
  CliResult r = RunCli(args);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // The rows and the definition as the CSV sweep wrote them; the provenance
  // (docs/provenance.md) is the merge's own: its command and the .h5 read.
  const std::string merged = ReadFile(dir + "/from_h5.csv");
  EXPECT_EQ(WithoutProvenanceLines(merged), WithoutProvenanceLines(ReadFile(csv)));
  EXPECT_NE(merged.find("# provenance.source_1: " + h5 + " ("), std::string::npos) << merged;
  EXPECT_NE(merged.find("--merge " + h5 + " --out " + dir + "/from_h5.csv\n"), std::string::npos) << merged;
  args = sweep;
  args.insert(args.end(), {"--merge", csv, "--out", dir + "/from_csv.h5"});
  r = RunCli(args);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  r = RunCli({"info", dir + "/from_csv.h5"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("sweep results (HDF5)"), std::string::npos) << r.out;
  ASSERT_EQ(RunCli({"sweep-plot", csv, "--out-dir", dir + "/plot_csv"}).exit_code, 0);
  r = RunCli({"sweep-plot", dir + "/from_csv.h5", "--out-dir", dir + "/plot_h5"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(ReadFile(dir + "/plot_h5/fragility.csv"), ReadFile(dir + "/plot_csv/fragility.csv"));
}

}  // namespace
}  // namespace rocklab::test
