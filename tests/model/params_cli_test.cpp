// `rocklab params --polygon` as a user runs it: both sides named in the text
// and the JSON, the existing keys meaning the +x side, and one-line errors
// naming the file and line.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "daq/rig_config.h"
#include "model/test_record.h"
#include "tests/model/fit_synthetic.h"
#include "tests/tools/run_cli.h"

namespace rocklab::test {
namespace {

std::string Write(const std::string& dir, const std::string& name, const std::string& text) {
  const std::string path = dir + "/" + name;
  std::ofstream(path) << text;
  return path;
}

int CountLines(const std::string& s) { return static_cast<int>(std::count(s.begin(), s.end(), '\n')); }

// Oracle: the right trapezoid of block_test computed by hand (alpha_+ =
// atan(11/20), alpha_- = atan(7/20), mu onto + 504/702, onto - 0.8), to the
// 1e-12 that JSON's 17 digits keep.
TEST(CliParams, PolygonJsonHasBothSides) {
  const std::string dir = ScratchDir("params_polygon");
  const std::string csv = Write(dir, "trapezoid.csv", "x,z\n0,0\n0.4,0\n0.2,1\n0,1\n");
  const CliResult r = RunCli({"params", "--polygon", csv, "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_NEAR(j.at("alpha").get<double>(), std::atan(11.0 / 20), 1e-12);  // the +x side
  EXPECT_NEAR(j.at("mu").get<double>(), 504.0 / 702, 1e-12);
  EXPECT_NEAR(j.at("plus_side").at("alpha").get<double>(), std::atan(11.0 / 20), 1e-12);
  EXPECT_NEAR(j.at("minus_side").at("alpha").get<double>(), std::atan(7.0 / 20), 1e-12);
  EXPECT_NEAR(j.at("minus_side").at("mu").get<double>(), 0.8, 1e-12);
  EXPECT_NEAR(j.at("minus_side").at("R").get<double>(), std::sqrt(449.0) / 45, 1e-12);
  EXPECT_TRUE(j.at("minus_side").contains("p"));
  EXPECT_FALSE(j.at("symmetric").get<bool>());
  EXPECT_NEAR(j.at("width").get<double>(), 0.4, 1e-12);
  EXPECT_NEAR(j.at("height").get<double>(), 1.0, 1e-12);
  EXPECT_TRUE(j.at("chamfer").is_null());
  EXPECT_EQ(j.at("vertices").get<int>(), 4);
  const CliResult text = RunCli({"params", "--polygon", csv});
  ASSERT_EQ(text.exit_code, 0) << text.err;
  for (const char* word : {"asymmetric", "+x", "-x", "0.8000"}) {
    EXPECT_NE(text.out.find(word), std::string::npos) << word << " missing in\n" << text.out;
  }
}

// Oracle: a rectangle given as a polygon is the rectangle (same keys, same
// values to rounding), and its two sides are the same.
TEST(CliParams, RectanglePolygonEqualsRectangle) {
  const std::string dir = ScratchDir("params_rect");
  const std::string csv = Write(dir, "rect.csv", "x,z\n-0.1235,0\n0.1235,0\n0.1235,1\n-0.1235,1\n");
  const CliResult p = RunCli({"params", "--polygon", csv, "--json"});
  const CliResult r = RunCli({"params", "--width", "0.247", "--height", "1.0", "--json"});
  ASSERT_EQ(p.exit_code, 0) << p.err;
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const auto jp = nlohmann::json::parse(p.out);
  const auto jr = nlohmann::json::parse(r.out);
  for (const char* key : {"alpha", "p", "mu", "R", "I_O_per_mass", "mu_housner"}) {
    EXPECT_NEAR(jp.at(key).get<double>(), jr.at(key).get<double>(), 1e-13) << key;
  }
  EXPECT_TRUE(jp.at("symmetric").get<bool>());
  EXPECT_TRUE(jr.at("symmetric").get<bool>());
  EXPECT_NEAR(jr.at("minus_side").at("p").get<double>(), jr.at("p").get<double>(), 1e-13);
}

struct BadCase {
  std::string name;
  std::string csv;       // file text; empty: no file
  std::string expected;  // in the one-line message; @ is the file's path
};

class CliParamsBadPolygon : public ::testing::TestWithParam<BadCase> {};

TEST_P(CliParamsBadPolygon, ExitsWith2NamingFileAndLine) {
  const std::string dir = ScratchDir("params_bad");
  const std::string path = GetParam().csv.empty() ? dir + "/none.csv" : Write(dir, GetParam().name + ".csv", GetParam().csv);
  std::string expected = GetParam().expected;
  if (expected[0] == '@') expected = path + expected.substr(1);
  const CliResult r = RunCli({"params", "--polygon", path});
  EXPECT_EQ(r.exit_code, 2) << r.out << r.err;
  EXPECT_EQ(CountLines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find(expected), std::string::npos) << r.err;
}

INSTANTIATE_TEST_SUITE_P(
    Cases, CliParamsBadPolygon,
    ::testing::Values(BadCase{"Missing", "", "@: cannot open"},
                      BadCase{"Header", "x,y\n0,0\n1,0\n1,1\n", "@:1: the header must be x,z"},
                      BadCase{"NotANumber", "x,z\n0,0\n1,0\n1,one\n", "@:4: expected two finite numbers"},
                      BadCase{"Crossing", "x,z\n0,0\n1,1\n1,0\n0,1\n", "@:2: the edge from line 2 to line 3"},
                      BadCase{"Overhang", "x,z\n0,0\n0.1,0\n0.1,0.1\n1,0.1\n1,0.2\n0,0.2\n", "@: centroid x"}),
    [](const ::testing::TestParamInfo<BadCase>& param_info) { return param_info.param.name; });

TEST(CliParams, PolygonAndWidthAreExclusive) {
  const std::string dir = ScratchDir("params_both");
  const std::string csv = Write(dir, "tri.csv", "x,z\n0,0\n1,0\n0.5,1\n");
  const CliResult r = RunCli({"params", "--polygon", csv, "--width", "1", "--height", "1"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("not both"), std::string::npos) << r.err;
}

// The rig file's [block] polygon key: the lab rig with a polygon inserted
// after `chamfer_m` (line 15), so the polygon is on line 16.
std::string LabRigWith(const std::string& block_lines) {
  std::ifstream in(std::string(ROCKLAB_SOURCE_DIR) + "/data/rigs/lab_rig.toml");
  std::ostringstream out;
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    out << line << "\n";
    if (++n == 15) out << block_lines;
  }
  return out.str();
}

std::string RigError(const std::string& block_lines) {
  try {
    daq::ParseRigConfig(LabRigWith(block_lines), "rig.toml");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

// Oracle: the values written, and the contract (file, line, key).
TEST(RigPolygon, InlineVerticesAndErrorsNamingLineAndKey) {
  const auto rig = daq::ParseRigConfig(
      LabRigWith("polygon = [[-0.125, 0.0], [0.125, 0.0], [0.125, 1.0], [-0.125, 1.0]]\n"), "rig.toml");
  ASSERT_EQ(rig.block.polygon_m.size(), 4u);
  EXPECT_EQ(rig.block.polygon_m[2][1], 1.0);
  EXPECT_EQ(rig.block.polygon_line, 16);
  EXPECT_TRUE(daq::ParseRigConfig(LabRigWith(""), "rig.toml").block.polygon_m.empty());
  EXPECT_NE(RigError("polygon = [[0, 0], [1], [1, 1]]\n").find("rig.toml:16: key 'block.polygon' vertex 1 must be a pair"),
            std::string::npos);
  EXPECT_NE(RigError("polygon = [[0, 0], [1, 0]]\n").find("rig.toml:16: key 'block.polygon' must list at least 3"),
            std::string::npos);
  EXPECT_NE(RigError("polygon = [[0, 0], [1, 0], [1, \"a\"]]\n").find("vertex 2"), std::string::npos);
  EXPECT_NE(RigError("polygon = 3\n").find("key 'block.polygon' must be an array"), std::string::npos);
}

// Oracle: `fit --rig` with a polygon equal to block 1's rectangle gives the
// rectangle's theory row and band (the same numbers as --width/--height, to
// rounding); a polygon that cannot stand is one line naming the rig file,
// line and key.
TEST(RigPolygon, FitUsesTheRigPolygon) {
  const std::string dir = ScratchDir("rig_polygon");
  const model::BlockParams block1{0.235, 3.884, 0.937};
  model::WriteThetaCsv(dir + "/free.csv", SyntheticFree(block1, 0.6 * block1.alpha, 0.3, 8.0, 500, 0.02, 1));
  const std::string rig = Write(dir, "rig.toml",
                                LabRigWith("polygon = [[-0.1235, 0.0], [0.1235, 0.0], [0.1235, 1.0], [-0.1235, 1.0]]\n"));
  const CliResult p = RunCli({"fit", "--input", dir + "/free.csv", "--rig", rig, "--json"});
  const CliResult w = RunCli({"fit", "--input", dir + "/free.csv", "--width", "0.247", "--height", "1", "--json"});
  ASSERT_EQ(p.exit_code, 0) << p.err;
  ASSERT_EQ(w.exit_code, 0) << w.err;
  const auto jp = nlohmann::json::parse(p.out);
  const auto jw = nlohmann::json::parse(w.out);
  for (const char* key : {"alpha", "p", "mu"}) {
    EXPECT_NEAR(jp.at("theory").at(key).get<double>(), jw.at("theory").at(key).get<double>(), 1e-12) << key;
  }
  for (const char* key : {"lo", "hi"}) {
    EXPECT_NEAR(jp.at("alpha_band").at(key).get<double>(), jw.at("alpha_band").at(key).get<double>(), 1e-12) << key;
  }
  const std::string bad = Write(dir, "bad.toml",
                                LabRigWith("polygon = [[0, 0], [0.1, 0], [0.1, 0.1], [1, 0.1], [1, 0.2], [0, 0.2]]\n"));
  const CliResult r = RunCli({"fit", "--input", dir + "/free.csv", "--rig", bad});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_EQ(CountLines(r.err), 1) << r.err;
  EXPECT_NE(r.err.find(bad + ":16: key 'block.polygon' centroid x"), std::string::npos) << r.err;
}


// Oracle: the escape rule of docs/reliability.md: what the user's terminal
// receives from `params --polygon` and `fit --input` on files whose header
// holds an ESC sequence and a megabyte-long line is one line of printable
// text naming the file and line, the bytes shown as \x1b and the long line
// cut with the count of bytes left out.
TEST(CliParams, HostileHeadersReachTheTerminalEscapedAndCut) {
  const std::string dir = ScratchDir("params_hostile");
  const std::string esc = Write(dir, "esc.csv", "x,\x1b]0;pwned\x07\x1b[2J\nz\n0,0\n");
  const std::string huge = Write(dir, "huge.csv", "time," + std::string(1 << 20, 'A') + "\n0,0\n");
  for (const auto& args : std::vector<std::vector<std::string>>{{"params", "--polygon", esc},
                                                                {"fit", "--input", esc},
                                                                {"params", "--polygon", huge},
                                                                {"fit", "--input", huge}}) {
    const CliResult r = RunCli(args);
    EXPECT_EQ(r.exit_code, 2) << r.err;
    EXPECT_LT(r.err.size(), 600u) << args[2];
    EXPECT_EQ(CountLines(r.err), 1) << r.err;
    for (unsigned char c : r.err.substr(0, r.err.size() - 1)) {
      EXPECT_TRUE(c >= 0x20 && c != 0x7f) << "byte " << int(c) << " in " << r.err;
    }
    EXPECT_NE(r.err.find(args[2] + ":1:"), std::string::npos) << r.err;
    if (args[2] == esc) {
      EXPECT_NE(r.err.find("\\x1b]0;pwned\\x07\\x1b[2J"), std::string::npos) << r.err;
    }
    if (args[2] == huge) {
      EXPECT_NE(r.err.find(" bytes more]"), std::string::npos) << r.err;
    }
  }
}

}  // namespace
}  // namespace rocklab::test
