// Rig configuration: the bundled example loads with the values written in it
// (oracle: the file itself), and every error names file, line and key (oracle:
// the line numbers of the hand-written snippets below).
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "daq/rig_config.h"
#include "tests/daq/daq_test_util.h"

namespace rocklab::daq {
namespace {

std::string Error(const std::string& text) {
  try {
    ParseRigConfig(text, "rig.toml");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "no error";
}

const char* kMinimal = R"(name = "r"
sample_rate_hz = 100
[block]
width_m = 0.2
height_m = 0.8
[mirror]
lever_m = 1.5
[[channel]]
name = "s"
sensor = "mirror.s"
)";

TEST(RigConfig, LoadsTheBundledExample) {
  const RigConfig rig = LoadRigConfig(test::LabRigPath());
  EXPECT_EQ(rig.name, "lab-table-A");
  EXPECT_EQ(rig.sample_rate_hz, 1000.0);
  EXPECT_DOUBLE_EQ(rig.block.pivot_half_width_m(), 0.125);
  EXPECT_FALSE(rig.block.alpha.has_value());
  EXPECT_TRUE(rig.mirror.present);
  EXPECT_EQ(rig.mirror.lever_m, 2.0);
  ASSERT_EQ(rig.cameras.size(), 2u);
  EXPECT_EQ(rig.cameras[1].leds[1].name, "H2");
  EXPECT_EQ(rig.cameras[1].leds[1].z_m, 0.85);
  EXPECT_EQ(rig.out_of_plane.spacing_m, 0.20);
  EXPECT_EQ(rig.channels.size(), 14u);
  const ChannelConfig* acc = rig.FindSensor("table.acceleration");
  ASSERT_NE(acc, nullptr);
  EXPECT_EQ(acc->name, "table_acc");
  EXPECT_EQ(acc->gain, 9.81);
  EXPECT_EQ(acc->unit, "m/s^2");
  EXPECT_EQ(rig.checks.disagree_rad, 0.005);
  EXPECT_EQ(rig.HalfWindow(rig.theta_dot), 5);
  EXPECT_EQ(rig.HalfWindow(rig.table), 50);
}

TEST(RigConfig, MinimalFileTakesDefaults) {
  const RigConfig rig = ParseRigConfig(kMinimal, "rig.toml");
  EXPECT_EQ(rig.channels[0].gain, 1.0);
  EXPECT_EQ(rig.channels[0].unit, "m");
  EXPECT_EQ(rig.checks.sliding_m, CheckTolerances{}.sliding_m);
  EXPECT_TRUE(rig.cameras.empty());
}

TEST(RigConfig, ErrorsNameFileLineAndKey) {
  std::string text = kMinimal;
  // lever_m on line 7 made negative.
  EXPECT_EQ(Error(std::string(text).replace(text.find("1.5"), 3, "-1")),
            "rig.toml:7: key 'mirror.lever_m' must be in [0.001, 100] m, got -1");
  // A missing key is reported at its table's line.
  EXPECT_EQ(Error(std::string(text).replace(text.find("lever_m = 1.5\n"), 14, "")),
            "rig.toml:6: key 'mirror.lever_m' is missing");
  // Wrong type.
  EXPECT_EQ(Error(std::string(text).replace(text.find("100"), 3, "\"fast\"")),
            "rig.toml:2: key 'sample_rate_hz' must be a number");
  // A typo is not ignored.
  EXPECT_EQ(Error(text + "gian = 2\n"), "rig.toml:11: key 'channel.gian' is not a rig configuration key");
  // Unknown sensor role.
  EXPECT_NE(Error(std::string(text).replace(text.find("mirror.s\""), 8, "camera.x")).find(
                "rig.toml:10: key 'channel.sensor' names an unknown sensor 'camera.x'"),
            std::string::npos);
  // TOML syntax error with its line.
  EXPECT_EQ(Error(std::string(text).replace(text.find("width_m = 0.2"), 13, "width_m = = 0.2"))
                .rfind("rig.toml:4: ", 0),
            0u);
  // Saturation limits in the wrong order.
  EXPECT_EQ(Error(text + "raw_min = 5\nraw_max = 1\n"),
            "rig.toml:12: key 'channel.raw_max' must be > raw_min");
  // A differentiator window too short for its order at the sample rate.
  EXPECT_EQ(Error(std::string(text) + "[theta_dot]\nwindow_s = 0.02\norder = 4\n"),
            "rig.toml:12: key 'theta_dot.window_s' must be in [0.04, 20] s at sample_rate_hz 100 (5 to 2001 "
            "samples for order 4), got 0.02");
}

TEST(RigConfig, LedNeedsBothCoordinates) {
  const std::string text = std::string(kMinimal) +
                           "[[camera]]\nname = \"c\"\nled = [{ name = \"A\", x_m = 0, z_m = 0.1 }]\n"
                           "[[channel]]\nname = \"ax\"\nsensor = \"c.A.x\"\n";
  EXPECT_EQ(Error(text), "rig.toml:14: key 'channel.sensor' maps 'c.A.x' but no channel maps 'c.A.z'");
}

TEST(RigConfig, MissingFileNamesIt) {
  try {
    LoadRigConfig("/nonexistent/rig.toml");
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "/nonexistent/rig.toml: cannot open the rig file");
  }
}

}  // namespace
}  // namespace rocklab::daq

namespace rocklab::daq {
namespace {

// The complete example of docs/acquisition.md (moved there from README) is
// the bundled rig file (oracle: the file).
TEST(RigConfig, ReadmeExampleIsTheBundledRigFile) {
  std::ifstream readme(std::string(ROCKLAB_SOURCE_DIR) + "/docs/acquisition.md");
  std::stringstream text;
  text << readme.rdbuf();
  const std::string s = text.str();
  const size_t begin = s.find("```toml\n");
  ASSERT_NE(begin, std::string::npos);
  const size_t end = s.find("```\n", begin + 8);
  std::ifstream rig(test::LabRigPath());
  std::stringstream rig_text;
  rig_text << rig.rdbuf();
  EXPECT_EQ(s.substr(begin + 8, end - begin - 8), rig_text.str());
}

}  // namespace
}  // namespace rocklab::daq

namespace rocklab::daq {
namespace {

// Rig values are bounded, the message naming the key and
// the allowed range. Oracle: the ranges of rig_config.h and docs/acquisition.md.
std::string RigError(const std::string& extra, double rate_hz = 1000) {
  std::ostringstream text;
  text << "name = \"r\"\nsample_rate_hz = " << rate_hz
       << "\n[block]\nwidth_m = 0.2\nheight_m = 0.8\n[mirror]\nlever_m = 1.0\n" << extra
       << "\n[[channel]]\nname = \"s\"\nsensor = \"mirror.s\"\n";
  try {
    ParseRigConfig(text.str(), "rig.toml");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "accepted";
}

TEST(RigConfigRanges, ValuesOutOfRangeNameTheKeyAndTheRange) {
  EXPECT_EQ(RigError("[table]\nwindow_s = 2.5"),
            "rig.toml:9: key 'table.window_s' must be in [0.004, 2] s at sample_rate_hz 1000 (5 to 2001 "
            "samples for order 4), got 2.5");
  EXPECT_EQ(RigError("[table]\norder = 4294967298"),
            "rig.toml:9: key 'table.order' must be in [2, 6], got 4294967298");
  EXPECT_EQ(RigError("[checks]\nmin_leds = 4294967298"),
            "rig.toml:9: key 'checks.min_leds' must be in [2, 64], got 4294967298");
  EXPECT_EQ(RigError("", 1e308), "rig.toml:2: key 'sample_rate_hz' must be in [1, 100000] Hz, got 1e+308");
  EXPECT_EQ(RigError("", 0), "rig.toml:2: key 'sample_rate_hz' must be in [1, 100000] Hz, got 0");
  // The default table window (0.1 s) holds 10001 samples at 100 kHz: named too.
  EXPECT_NE(RigError("", 100000).find("key 'table.window_s' must be in [4e-05, 0.02] s at sample_rate_hz "
                                      "100000 (5 to 2001 samples for order 4), got 0.1 (the default)"),
            std::string::npos)
      << RigError("", 100000);
  EXPECT_EQ(RigError("[checks]\nsigmas = 1e9"), "rig.toml:9: key 'checks.sigmas' must be in (0, 1000], got 1e+09");
}

// Within the bounds, the largest window is cheap to set up: the rig of the
// report (window_s = 2 at 1 kHz, 103 s and 245 MB before) and 20 kHz with
// the default table window (205 s before) build their Processor at once.
TEST(RigConfigRanges, LargestWindowsBuildAProcessor) {
  for (const auto& [extra, rate] : {std::pair<std::string, double>{"[table]\nwindow_s = 2", 1000},
                                    std::pair<std::string, double>{"", 20000}}) {
    std::ostringstream text;
    text << "name = \"r\"\nsample_rate_hz = " << rate
         << "\n[block]\nwidth_m = 0.2\nheight_m = 0.8\n[mirror]\nlever_m = 1.0\n" << extra
         << "\n[[channel]]\nname = \"s\"\nsensor = \"mirror.s\"\n[[channel]]\nname = \"x\"\n"
            "sensor = \"table.displacement\"\n";
    const RigConfig rig = ParseRigConfig(text.str(), "rig.toml");
    EXPECT_EQ(rig.HalfWindow(rig.table), 1000);
    test::CollectSink sink;
    Processor p(rig, {"s", "x"}, "in.csv", sink);
    EXPECT_EQ(p.table_delay_samples(), 1000);
  }
}

// [table] lag_s (docs/acquisition.md): a delay in [0, m / rate] s, rounded to
// samples; anything else names the file, the line, the key and the range.
// Oracle: the half window of the default table window (0.1 s at 1 kHz: 50
// samples, 0.05 s) and the snippet's line numbers.
TEST(RigConfigRanges, TableLagIsBoundedByTheHalfWindow) {
  EXPECT_EQ(RigError("[table]\nlag_s = -0.001"),
            "rig.toml:9: key 'table.lag_s' must be in [0, 0.05] s (0: the window's causal end-point, 0.05: its "
            "centre, 50 samples at sample_rate_hz 1000), got -0.001");
  EXPECT_EQ(RigError("[table]\nlag_s = 0.06"),
            "rig.toml:9: key 'table.lag_s' must be in [0, 0.05] s (0: the window's causal end-point, 0.05: its "
            "centre, 50 samples at sample_rate_hz 1000), got 0.06");
  EXPECT_EQ(RigError("[table]\nwindow_s = 0.02\nlag_s = 1e300"),
            "rig.toml:10: key 'table.lag_s' must be in [0, 0.01] s (0: the window's causal end-point, 0.01: its "
            "centre, 10 samples at sample_rate_hz 1000), got 1e+300");
  EXPECT_EQ(RigError("[table]\nlag_s = \"short\""), "rig.toml:9: key 'table.lag_s' must be a number");
  EXPECT_EQ(RigError("[table]\nlag_s = nan"), "rig.toml:9: key 'table.lag_s' must be finite");
  // theta_dot is always centred: the key is not one of its section's.
  EXPECT_EQ(RigError("[theta_dot]\nlag_s = 0.001"), "rig.toml:9: key 'theta_dot.lag_s' is not a rig configuration key");

  auto lag = [](const std::string& table) {
    const std::string text =
        "name = \"r\"\nsample_rate_hz = 1000\n[block]\nwidth_m = 0.2\nheight_m = 0.8\n[table]\n" + table +
        "\n[[channel]]\nname = \"x\"\nsensor = \"table.displacement\"\n";
    return ParseRigConfig(text, "rig.toml");
  };
  EXPECT_FALSE(lag("").table.lag_s.has_value());
  EXPECT_EQ(lag("").LagSamples(lag("").table), 50);  // absent: the centre
  EXPECT_EQ(lag("lag_s = 0").LagSamples(lag("lag_s = 0").table), 0);
  EXPECT_EQ(lag("lag_s = 0.0204").LagSamples(lag("lag_s = 0.0204").table), 20);  // rounded to samples
  EXPECT_EQ(lag("lag_s = 0.05").LagSamples(lag("lag_s = 0.05").table), 50);
}

}  // namespace
}  // namespace rocklab::daq
