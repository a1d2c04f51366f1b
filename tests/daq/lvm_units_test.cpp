// LabVIEW units (Y_Unit_Label) read with the channels, and checked against
// the rig (daq::CheckFileUnits): a rig channel with raw_unit refuses a file
// that says otherwise; one calibrated by the identity warns.
// Oracle: the fixture text (the labels as written) and the rig snippets'
// line numbers.
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "daq/rig_config.h"
#include "daq/source.h"
#include "tests/daq/daq_test_util.h"

namespace rocklab::daq {
namespace {

// As Write To Measurement File writes it: a file header, then a segment
// header with one column per channel (a trailing tab), Y_Unit_Label among
// Date and Time, and a Comment column.
const char* kHeader =
    "LabVIEW Measurement\t\nWriter_Version\t2\nReader_Version\t2\nSeparator\tTab\nDecimal_Separator\t.\n"
    "Multi_Headings\tNo\nX_Columns\tOne\nTime_Pref\tRelative\nOperator\tlab\nDate\t2026/11/02\n"
    "Time\t14:03:21.5\n***End_of_Header***\t\n\n";

std::string Segment(const std::string& units, double x0) {
  return "Channels\t2\t\nSamples\t2\t2\t\nDate\t2026/11/02\t2026/11/02\t\nTime\t14:03:21.5\t14:03:21.5\t\n"
         "Y_Unit_Label\t" + units + "\t\nX_Dimension\tTime\tTime\t\nX0\t" + std::to_string(x0) + "\t" +
         std::to_string(x0) + "\t\nDelta_X\t0.5\t0.5\t\n***End_of_Header***\t\t\n"
         "X_Value\ts\td\tComment\n" + std::to_string(x0) + "\t1\t2\n" + std::to_string(x0 + 0.5) + "\t3\t4\tok\n";
}

TEST(LvmUnits, YUnitLabelGivesEachChannelItsUnit) {
  const std::string path = test::WriteFile("units.lvm", std::string(kHeader) + Segment("mm\tVolts", 0));
  auto source = OpenSource(path, SourceOptions{});
  EXPECT_EQ(source->channel_units(), (std::vector<std::string>{"mm", "Volts"}));
  EXPECT_TRUE(source->has_comments());
}

TEST(LvmUnits, AFileWithoutLabelsHasEmptyUnitsAndCsvNone) {
  const std::string lvm = test::WriteFile("nounits.lvm",
                                          std::string(kHeader) +
                                              "Channels\t1\nSamples\t1\nDelta_X\t1\n***End_of_Header***\n"
                                              "X_Value\ta\n0\t1\n");
  auto source = OpenSource(lvm, SourceOptions{});
  EXPECT_EQ(source->channel_units(), (std::vector<std::string>{""}));
  EXPECT_FALSE(source->has_comments());
  SourceOptions o;
  o.sample_rate_hz = 10;
  auto csv = OpenSource(test::WriteFile("units.csv", "time,a\n0,1\n"), o);
  EXPECT_TRUE(csv->channel_units().empty());
}

// A later segment with another unit: its rows are kept, the first
// segment's unit stands, and the disagreement is a counted warning.
TEST(LvmUnits, ALaterSegmentWithAnotherUnitIsReported) {
  const std::string path =
      test::WriteFile("units2.lvm", std::string(kHeader) + Segment("mm\tV", 0) + "\n" + Segment("m\tV", 1));
  SourceOptions o;
  const test::SourceRead r = test::ReadSource(path, o);
  EXPECT_EQ(r.frames.size(), 4u);
  EXPECT_EQ(r.stats.warnings, 1);
  ASSERT_EQ(r.problems.size(), 1u);
  EXPECT_NE(r.problems[0].find("segment 2 gives channel 's' the unit 'm' where segment 1 says 'mm'"),
            std::string::npos)
      << r.problems[0];
}

const char* kRig = R"(name = "r"
sample_rate_hz = 100
[block]
width_m = 0.2
height_m = 0.8
[mirror]
lever_m = 1.5
[[channel]]
name = "s"
sensor = "mirror.s"
raw_unit = "V"
gain = 0.01
[[channel]]
name = "d"
sensor = "mirror.n"
)";

TEST(LvmUnits, ARigRawUnitRefusesAFileThatSaysOtherwise) {
  const RigConfig rig = ParseRigConfig(kRig, "rig.toml");
  EXPECT_EQ(rig.channels[0].raw_unit, "V");
  // Agreeing units: nothing to say.
  EXPECT_TRUE(CheckFileUnits(rig, {"s", "d"}, {"V", "m"}, "x.lvm").empty());
  // A file stating none: nothing to check.
  EXPECT_TRUE(CheckFileUnits(rig, {"s", "d"}, {}, "x.lvm").empty());
  try {
    CheckFileUnits(rig, {"s", "d"}, {"mm", ""}, "x.lvm");
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("rig.toml:8: channel 's' (sensor 'mirror.s') has raw_unit 'V' but x.lvm says its values "
                     "are in 'mm'"),
              std::string::npos)
        << m;
  }
}

TEST(LvmUnits, AnIdentityCalibrationWithAnotherFileUnitWarns) {
  const RigConfig rig = ParseRigConfig(kRig, "rig.toml");
  // Channel d: gain 1, offset 0, unit m (the default): the file's mm would
  // be read as metres.
  const std::vector<std::string> w = CheckFileUnits(rig, {"s", "d"}, {"V", "mm"}, "x.lvm");
  ASSERT_EQ(w.size(), 1u);
  EXPECT_NE(w[0].find("rig.toml:13: channel 'd' (sensor 'mirror.n') is in 'm' with gain 1 and offset 0"),
            std::string::npos)
      << w[0];
  EXPECT_NE(w[0].find("x.lvm says they are in 'mm'"), std::string::npos) << w[0];
}

}  // namespace
}  // namespace rocklab::daq
