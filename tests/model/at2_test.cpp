// PEER NGA .AT2 records through the one table-acceleration reader
// (ReadAccelerationRows: simulate --accel, synth, fit --accel, sweep). PEER
// records may not be redistributed: every record here is written by the test.
// Oracle: the record text: sample k at k DT s, value_g * 9.81 m/s^2 (the g of
// common/units.h), compared exactly (the same double product).
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/units.h"
#include "model/excitation.h"

namespace rocklab::model {
namespace {

std::string Write(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + name;
  std::ofstream(path, std::ios::binary) << text;
  return path;
}

std::string ErrorOf(const std::string& path) {
  try {
    ReadAccelerationRows(path);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

const char* kHead =
    "PEER NGA STRONG MOTION DATABASE RECORD\n"
    "Test Valley, 1/1/2000, Synthetic Station, 090\n"
    "ACCELERATION TIME SERIES IN UNITS OF G\n";

// The newer style: "NPTS=  7, DT=   .0100 SEC", five values to a line.
TEST(PeerAt2, NptsEqualsStyleFiveToALine) {
  const std::string path = Write("new.AT2", std::string(kHead) +
                                                "NPTS=      7, DT=   .0100 SEC\n"
                                                "  .1000E-01  -.2000E-01   .3000E+00  0.0000E+00  -.5000E-02\n"
                                                "  .6000E-01   .7000E-01\n");
  const AccelerationRows rows = ReadAccelerationRows(path);
  const std::vector<double> g = {0.01, -0.02, 0.3, 0.0, -0.005, 0.06, 0.07};
  ASSERT_EQ(rows.time_s.size(), g.size());
  for (std::size_t k = 0; k < g.size(); ++k) {
    EXPECT_EQ(rows.time_s[k], static_cast<double>(k) * 0.01);
    EXPECT_EQ(rows.accel_mps2[k], g[k] * common::kGravity);
  }
  EXPECT_EQ(rows.line[4], 5);  // the fifth value is on line 5, the sixth on 6
  EXPECT_EQ(rows.line[5], 6);
  // The same record as a forcing (simulate --accel).
  const SampledAcceleration forcing = ReadAccelerationCsv(path);
  EXPECT_EQ(forcing.end_s(), 0.06);
}

// The older style: "9    0.0050    NPTS, DT", eight values to a line, a file
// named .txt (recognised by its fourth line).
TEST(PeerAt2, ValuesFirstStyleEightToALineByContent) {
  const std::string path = Write("old.txt", std::string(kHead) +
                                                "9    0.0050    NPTS, DT\n"
                                                " 1.0E-3 2.0E-3 3.0E-3 4.0E-3 5.0E-3 6.0E-3 7.0E-3 8.0E-3\r\n"
                                                " 9.0E-3\r\n\n");
  const AccelerationRows rows = ReadAccelerationRows(path);
  ASSERT_EQ(rows.time_s.size(), 9u);
  EXPECT_EQ(rows.time_s[8], 8 * 0.005);
  EXPECT_EQ(rows.accel_mps2[8], 9.0e-3 * common::kGravity);
}

// Velocity and displacement records, an NPTS that disagrees with the values
// (either way) and a bad value: clear errors naming file and line.
TEST(PeerAt2, ClearErrors) {
  const std::string vt2 = Write("rec.VT2", "PEER\nx\nVELOCITY TIME SERIES IN UNITS OF CM/S\nNPTS= 2, DT= .01 SEC\n1 2\n");
  EXPECT_NE(ErrorOf(vt2).find("rec.VT2: a PEER velocity (.VT2) or displacement (.DT2) record"), std::string::npos)
      << ErrorOf(vt2);
  const std::string dt2 = Write("dt2.AT2", "PEER\nx\nDISPLACEMENT TIME SERIES IN UNITS OF CM\nNPTS= 2, DT= .01 SEC\n1 2\n");
  EXPECT_NE(ErrorOf(dt2).find("dt2.AT2:3: a PEER velocity or displacement record"), std::string::npos)
      << ErrorOf(dt2);
  const std::string few = Write("few.AT2", std::string(kHead) + "NPTS=  4, DT= .01 SEC\n.1 .2 .3\n");
  EXPECT_NE(ErrorOf(few).find("few.AT2:4: NPTS 4 but the file has 3 values"), std::string::npos) << ErrorOf(few);
  const std::string many = Write("many.AT2", std::string(kHead) + "NPTS=  2, DT= .01 SEC\n.1 .2\n.3\n");
  EXPECT_NE(ErrorOf(many).find("many.AT2:6: more values than NPTS 2"), std::string::npos) << ErrorOf(many);
  const std::string bad = Write("bad.AT2", std::string(kHead) + "NPTS=  2, DT= .01 SEC\n.1 x2\n");
  EXPECT_NE(ErrorOf(bad).find("bad.AT2:5: acceleration 'x2' is not a finite number (g)"), std::string::npos)
      << ErrorOf(bad);
  const std::string nodt = Write("nodt.AT2", std::string(kHead) + "4316 points\n.1 .2\n");
  EXPECT_NE(ErrorOf(nodt).find("nodt.AT2:4: expected NPTS and DT"), std::string::npos) << ErrorOf(nodt);
}

}  // namespace
}  // namespace rocklab::model
