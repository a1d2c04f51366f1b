// Every export sink writes beside its target and renames at Close(): a sink
// destroyed without Close() (an export that failed or stopped) leaves the
// previous files byte for byte and no temporary.
//
// Oracle: the bytes of files written by the test before the export, and
// the folder's listing; a closed sink's file read back by the HDF5 C
// library, libmatio and a CSV read as text.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <set>
#include <string>

#include "export/csv_writer.h"
#include "export/export.h"
#include "export/h5_writer.h"
#include "export/mat_writer.h"
#include "tests/export/readback.h"
#include "tests/scratch.h"

namespace rocklab::exporter {
namespace {

using test::Listing;
using test::Slurp;

// Two tables of a few rows each, as a log export writes them.
void Fill(TableSink& sink) {
  const std::vector<Column> columns = {{"time", ColumnType::kDouble, "s"}, {"seq", ColumnType::kInt, ""}};
  const int a = sink.AddTable("RL_RAW", columns);
  const int b = sink.AddTable("RL_TABLE", columns);
  Row row;
  row.Resize(2);
  for (int k = 0; k < 5000; ++k) {  // more than one HDF5 chunk (4096 rows)
    row.real[0] = 0.001 * k;
    row.integer[1] = k;
    sink.Append(a, row);
    sink.Append(b, row);
  }
}

class AtomicSink : public ::testing::TestWithParam<const char*> {};

TEST_P(AtomicSink, DestroyedBeforeCloseLeavesThePreviousFilesAndNoTemporary) {
  const std::string dir = test::ScratchDir(std::string("atomic_sink_") + (GetParam() + 1));
  const std::string out = dir + "/run" + GetParam();
  const bool csv = std::string(GetParam()) == ".csv";
  // The previous export's files, with bytes no writer would produce.
  const std::vector<std::string> previous =
      csv ? std::vector<std::string>{CsvWriter::TablePath(out, "RL_RAW"), CsvWriter::TablePath(out, "RL_TABLE")}
          : std::vector<std::string>{out};
  for (const std::string& p : previous) std::ofstream(p, std::ios::binary) << "previous export of " << p << "\n";
  const std::set<std::string> before = Listing(dir);
  {
    std::unique_ptr<TableSink> sink = OpenSink(out, false);
    Fill(*sink);
  }  // no Close(): the export failed
  for (const std::string& p : previous) EXPECT_EQ(Slurp(p), "previous export of " + p + "\n") << p;
  EXPECT_EQ(Listing(dir), before) << "a file under a new name, or a temporary left behind";
}

TEST_P(AtomicSink, CloseReplacesThePreviousFilesWhole) {
  const std::string dir = test::ScratchDir(std::string("atomic_sink_close_") + (GetParam() + 1));
  const std::string out = dir + "/run" + GetParam();
  std::ofstream(out, std::ios::binary) << "previous";
  std::unique_ptr<TableSink> sink = OpenSink(out, false);
  Fill(*sink);
  sink->Close();
  const std::string ext = GetParam();
  if (ext == ".h5") {
    const auto raw = test::ReadH5Table(out, "RL_RAW");
    ASSERT_EQ(raw.size(), 2u);
    EXPECT_EQ(raw[1].integer.size(), 5000u);
    EXPECT_EQ(raw[1].integer.back(), 4999);
  } else if (ext == ".mat") {
    const auto raw = test::ReadMatTable(out, "RL_RAW");
    ASSERT_EQ(raw.size(), 2u);
    EXPECT_EQ(raw[1].integer.size(), 5000u);
  } else {
    const auto table = test::ReadCsvTable(CsvWriter::TablePath(out, "RL_TABLE"));
    ASSERT_EQ(table.size(), 2u);
    ASSERT_EQ(table[1].text.size(), 5000u);
    EXPECT_EQ(table[1].text.back(), "4999");
  }
  for (const std::string& name : Listing(dir)) EXPECT_EQ(name.find(".tmp-"), std::string::npos) << name;
}

INSTANTIATE_TEST_SUITE_P(Formats, AtomicSink, ::testing::Values(".h5", ".mat", ".csv"));

}  // namespace
}  // namespace rocklab::exporter
