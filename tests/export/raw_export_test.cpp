// A raw LVM/CSV file through `export` (one table `data`) and the HDF5 table
// writer on its own.
//
// Oracle for the raw export: the DAQ's own source (daq::OpenSource), read
// independently of the export: every row's time and every channel value,
// NaN where the source gives NaN, must come back from each format.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "daq/source.h"
#include "export/export.h"
#include "export/h5_writer.h"
#include "tests/export/readback.h"
#include "tests/scratch.h"

namespace rocklab::exporter {
namespace {

const std::string kLvm = ROCKLAB_SOURCE_DIR "/data/samples/slip.lvm";

struct Truth {
  std::vector<std::string> names;
  std::vector<std::vector<double>> columns;  // time first
};

Truth ReadTruth(const std::string& path) {
  Truth t;
  auto source = daq::OpenSource(path, daq::SourceOptions{});
  t.names = source->channel_names();
  t.columns.resize(t.names.size() + 1);
  daq::Frame f;
  while (source->Next(f) == daq::ReadStatus::kFrame) {
    t.columns[0].push_back(f.time_s);
    for (std::size_t i = 0; i < t.names.size(); ++i) t.columns[i + 1].push_back(f.values[i]);
  }
  return t;
}

void ExpectSame(double want, double got, const std::string& what) {
  if (std::isnan(want)) {
    EXPECT_TRUE(std::isnan(got)) << what;
  } else {
    EXPECT_EQ(want, got) << what;
  }
}

std::string Dir() { return test::ScratchDir("raw_export"); }

TEST(RawExport, EveryFormatHoldsWhatTheSourceReads) {
  const Truth truth = ReadTruth(kLvm);
  ASSERT_GT(truth.columns[0].size(), 100u);
  bool any_nan = false;
  for (const auto& c : truth.columns) {
    for (double v : c) any_nan = any_nan || std::isnan(v);
  }
  ASSERT_TRUE(any_nan) << "the sample should have missing values to check NaN with";
  for (const std::string ext : {".h5", ".mat", ".csv"}) {
    const std::string out = Dir() + "/slip" + ext;
    auto sink = OpenSink(out, true);
    ExportOptions o;
    o.units = {{"table_disp", "m"}};
    const ExportSummary s = ExportRaw(kLvm, o, *sink);
    sink->Close();
    EXPECT_EQ(s.rows, static_cast<std::int64_t>(truth.columns[0].size()));
    const auto read = ext == ".h5" ? test::ReadH5Table(out, "data")
                      : ext == ".mat" ? test::ReadMatTable(out, "data")
                                      : test::ReadCsvTable(out);
    // time, the channels, and slip.lvm's Comment column as `comment`.
    ASSERT_EQ(read.size(), truth.names.size() + 2) << ext;
    EXPECT_EQ(read[0].name, "time");
    EXPECT_EQ(read.back().name, "comment");
    for (std::size_t c = 0; c + 1 < read.size(); ++c) {
      if (c > 0) {
        EXPECT_EQ(read[c].name, truth.names[c - 1]) << ext;
      }
      ASSERT_EQ(read[c].size(), truth.columns[c].size()) << ext << " " << read[c].name;
      for (std::size_t r = 0; r < truth.columns[c].size(); ++r) {
        const double got = ext == ".csv" ? std::strtod(read[c].text[r].c_str(), nullptr) : read[c].real[r];
        ExpectSame(truth.columns[c][r], got, ext + " " + read[c].name + " row " + std::to_string(r));
      }
      if (ext == ".h5" && read[c].name == "table_disp") {
        EXPECT_EQ(read[c].unit, "m");
      }
      if (ext == ".h5" && c == 0) {
        EXPECT_EQ(read[c].unit, "s");
      }
    }
  }
}

// Oracle: the window's definition: s from the first row's time (slip.lvm
// starts at 0 s with 1 ms rows).
TEST(RawExport, WindowKeepsTheRowsBetweenStartAndEnd) {
  const Truth truth = ReadTruth(kLvm);
  const std::string out = Dir() + "/window.h5";
  auto sink = OpenSink(out, true);
  ExportOptions o;
  o.start_s = 0.1;
  o.end_s = 0.2;
  const ExportSummary s = ExportRaw(kLvm, o, *sink);
  sink->Close();
  const auto read = test::ReadH5Table(out, "data");
  std::size_t want = 0;
  for (double t : truth.columns[0]) want += (t - truth.columns[0][0] >= 0.1 && t - truth.columns[0][0] <= 0.2);
  ASSERT_FALSE(read.empty());
  EXPECT_EQ(read[0].real.size(), want);
  EXPECT_EQ(s.outside_window + s.rows, static_cast<std::int64_t>(truth.columns[0].size()));
  for (double t : read[0].real) {
    EXPECT_GE(t - truth.columns[0][0], 0.1);
    EXPECT_LE(t - truth.columns[0][0], 0.2);
  }
}

// Oracle: the rows appended. Chunks of 4 rows and 10 rows: two whole chunks
// and a partial one at Close; two tables interleaved; text with UTF-8.
TEST(H5Writer, AppendsRowsAcrossChunksAndTables) {
  const std::string out = Dir() + "/results.h5";
  {
    H5WriterOptions o;
    o.chunk_rows = 4;
    H5Writer w(out, o);
    const int a = w.AddTable("results", {{"alpha", ColumnType::kDouble, "rad"},
                                         {"runs", ColumnType::kInt, ""},
                                         {"name", ColumnType::kString, ""}});
    const int b = w.AddTable("other/table", {{"x", ColumnType::kDouble, "m"}});
    Row ra, rb;
    ra.Resize(3);
    rb.Resize(1);
    for (int i = 0; i < 10; ++i) {
      ra.real[0] = 0.1 * i;
      ra.integer[1] = i * i;
      ra.text[2] = "r\xC3\xA9sultat " + std::to_string(i);
      w.Append(a, ra);
      rb.real[0] = -i;
      if (i % 2 == 0) w.Append(b, rb);
    }
    w.DescribeFile("source", "test");
    w.Close();
  }
  const auto read = test::ReadH5Table(out, "results");
  ASSERT_EQ(read.size(), 3u);
  ASSERT_EQ(read[0].real.size(), 10u);
  for (int i = 0; i < 10; ++i) {
    EXPECT_EQ(read[0].real[static_cast<std::size_t>(i)], 0.1 * i);
    EXPECT_EQ(read[1].integer[static_cast<std::size_t>(i)], i * i);
    EXPECT_EQ(read[2].text[static_cast<std::size_t>(i)], "r\xC3\xA9sultat " + std::to_string(i));
  }
  EXPECT_EQ(read[0].unit, "rad");
  const auto other = test::ReadH5Table(out, "other_table");
  ASSERT_EQ(other.size(), 1u);
  EXPECT_EQ(other[0].real, (std::vector<double>{0, -2, -4, -6, -8}));
}

TEST(H5Writer, ThrowsNamingTheFileItCannotCreate) {
  try {
    H5Writer w("/nonexistent-dir/x.h5");
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent-dir/x.h5"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace rocklab::exporter
