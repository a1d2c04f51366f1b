// Every field of every rocklab LCM type through `export` and back, in each
// format, compared value by value.
//
// Oracle: lcm_types/ itself and LCM's wire format. The test parses each
// .lcm file's field list, encodes messages byte by byte from it (big-endian,
// as LCM specifies) with a distinct value per field and message, writes them
// to a log, exports it, and reads the files back with the HDF5 C library,
// libmatio and a CSV parser: each column must carry the value its field was
// given. A field added to an .lcm file and missing from export/fields.cpp
// fails here (its column is missing); so does a field table that maps a
// column to the wrong member (its values differ). Exact comparison: every
// format stores the double's bits (CSV with 17 significant digits).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>

#include "common/lcm_log.h"
#include "export/csv_writer.h"
#include "export/export.h"
#include "export/fields.h"
#include "tests/export/readback.h"
#include "tests/scratch.h"

namespace rocklab::exporter {
namespace {

struct LcmField {
  std::string type, name, dim;  // dim: "" for a scalar, else the count field or a number
};

struct LcmStruct {
  std::string name;
  std::vector<LcmField> fields;
};

LcmStruct ParseLcm(const std::filesystem::path& file) {
  std::ifstream in(file);
  LcmStruct s;
  s.name = file.stem().string();
  const std::regex field(
      R"(^\s*(int8_t|int16_t|int32_t|int64_t|double|float|boolean|byte|string)\s+(\w+)\s*(\[\s*(\w+)\s*\])?\s*;)");
  std::string line;
  while (std::getline(in, line)) {
    std::smatch m;
    if (std::regex_search(line, m, field)) s.fields.push_back({m[1], m[2], m[4]});
  }
  return s;
}

std::vector<LcmStruct> AllStructs() {
  std::vector<LcmStruct> out;
  for (const auto& e : std::filesystem::directory_iterator(ROCKLAB_SOURCE_DIR "/lcm_types")) {
    if (e.path().extension() == ".lcm") out.push_back(ParseLcm(e.path()));
  }
  std::sort(out.begin(), out.end(), [](const LcmStruct& a, const LcmStruct& b) { return a.name < b.name; });
  return out;
}

// The value each field of message k of type number ti carries.
struct Expected {
  std::string name;
  char kind{};  // 'd', 'i', 's'
  double real{};
  std::int64_t integer{};
  std::string text;
};

constexpr int kArrayLength = 3;
constexpr int kMessages = 3;

void PutBE(std::vector<std::uint8_t>& out, std::uint64_t v, int bytes) {
  for (int b = bytes - 1; b >= 0; --b) out.push_back(static_cast<std::uint8_t>(v >> (8 * b)));
}

// Encodes message k of `s` and lists the columns it must export as.
std::vector<std::uint8_t> Encode(const LcmStruct& s, std::int64_t fingerprint, int ti, int k,
                                 std::vector<Expected>& columns) {
  std::vector<std::uint8_t> out;
  PutBE(out, static_cast<std::uint64_t>(fingerprint), 8);
  std::map<std::string, int> counts;
  for (const LcmField& f : s.fields) {
    for (const LcmField& g : s.fields) {
      if (g.dim == f.name) counts[f.name] = kArrayLength;
    }
  }
  columns.clear();
  Expected time;
  time.name = "time";
  time.kind = 'd';
  columns.push_back(time);
  for (std::size_t fi = 0; fi < s.fields.size(); ++fi) {
    const LcmField& f = s.fields[fi];
    int n = 1;
    if (!f.dim.empty()) n = std::isdigit(static_cast<unsigned char>(f.dim[0])) ? std::stoi(f.dim) : counts.at(f.dim);
    for (int e = 0; e < n; ++e) {
      Expected x;
      x.name = f.dim.empty() ? f.name : f.name + "_" + std::to_string(e);
      if (f.type == "double" || f.type == "float") {
        x.kind = 'd';
        x.real = ti * 100 + static_cast<double>(fi) + 0.125 * (k + 1) + 0.001 * e;
        if (k == 2 && fi == 3) x.real = std::nan("");  // a NaN goes through too
        if (f.type == "double") {
          std::uint64_t bits;
          std::memcpy(&bits, &x.real, 8);
          PutBE(out, bits, 8);
        } else {
          const auto fl = static_cast<float>(x.real);
          x.real = fl;
          std::uint32_t bits;
          std::memcpy(&bits, &fl, 4);
          PutBE(out, bits, 4);
        }
      } else if (f.type == "string") {
        x.kind = 's';
        x.text = f.name + "_" + std::to_string(k) + (k == 1 ? ",\"q\"" : "") + "_\xC3\xA9\xE2\x82\xAC\xF0\x9F\x98\x80";
        PutBE(out, x.text.size() + 1, 4);
        out.insert(out.end(), x.text.begin(), x.text.end());
        out.push_back(0);
      } else {
        x.kind = 'i';
        int bytes = f.type == "int64_t" ? 8 : f.type == "int32_t" ? 4 : f.type == "int16_t" ? 2 : 1;
        if (counts.count(f.name)) {
          x.integer = kArrayLength;
        } else if (f.name == "utime") {
          x.integer = 1'700'000'000'000'000 + ti * 1000 + k * 1000 * 100;
        } else if (f.type == "boolean") {
          x.integer = k % 2;
        } else if (bytes == 1) {
          x.integer = static_cast<std::int64_t>((fi * 5 + static_cast<std::size_t>(k)) % 120) - 7;
        } else {
          x.integer = -(1000 * ti + 10 * static_cast<std::int64_t>(fi) + k) * (bytes == 8 ? 1'000'000'007 : 1);
        }
        PutBE(out, static_cast<std::uint64_t>(x.integer), bytes);
      }
      columns.push_back(x);
    }
  }
  for (const Expected& x : columns) {
    if (x.name == "utime") columns[0].real = static_cast<double>(x.integer) / 1e6;
  }
  return out;
}

class RoundTrip : public ::testing::Test {
 protected:
  void SetUp() override {
    // Each test case runs in its own process under ctest -j: a folder of
    // its own (a shared fixed one was removed by one case while another
    // wrote it: a flake seen once in 8 suite runs beside a CPU hog).
    dir_ = test::ScratchDir("roundtrip");
    log_ = (dir_ / "all_types.lcm").string();
    common::LogWriter w(log_);
    structs_ = AllStructs();
    ASSERT_EQ(structs_.size(), MessageTypes().size()) << "an .lcm file without a field table, or the reverse";
    expected_.resize(structs_.size());
    for (int k = 0; k < kMessages; ++k) {
      for (std::size_t ti = 0; ti < structs_.size(); ++ti) {
        const MessageType* type = nullptr;
        for (const MessageType& t : MessageTypes()) {
          if (structs_[ti].name == t.name) type = &t;
        }
        ASSERT_NE(type, nullptr) << structs_[ti].name << ".lcm has no field table in export/fields.cpp";
        std::vector<Expected> cols;
        const auto bytes = Encode(structs_[ti], type->fingerprint, static_cast<int>(ti), k, cols);
        ASSERT_TRUE(w.Write("T_" + structs_[ti].name, bytes.data(), bytes.size(), 1000 * k));
        expected_[ti].push_back(cols);
      }
    }
    ASSERT_TRUE(w.Close());
  }

  // `read` must hold exactly the expected columns of type ti, every value equal.
  void Compare(std::size_t ti, const std::vector<test::ReadColumn>& read, const std::string& format) {
    const std::vector<Expected>& first = expected_[ti][0];
    ASSERT_GE(read.size(), first.size()) << format << " " << structs_[ti].name;
    // After the fields only derived columns: a code field's FIELD_name, and
    // raw_frame_t's columns named after RL_DAQ_CONFIG's channels
    // (tests/export/metadata_test.cpp checks their values).
    for (std::size_t c = first.size(); c < read.size(); ++c) {
      const std::string& n = read[c].name;
      const bool code = n.size() > 5 && n.compare(n.size() - 5, 5, "_name") == 0 &&
                        FieldCodes(n.substr(0, n.size() - 5)) != nullptr;
      EXPECT_TRUE(code || structs_[ti].name == "raw_frame_t") << format << " " << structs_[ti].name << "." << n;
    }
    for (std::size_t c = 0; c < first.size(); ++c) {
      const test::ReadColumn& r = read[c];
      SCOPED_TRACE(format + " " + structs_[ti].name + "." + first[c].name);
      EXPECT_EQ(r.name, first[c].name);
      ASSERT_EQ(r.size(), static_cast<std::size_t>(kMessages));
      for (int k = 0; k < kMessages; ++k) {
        const Expected& x = expected_[ti][static_cast<std::size_t>(k)][c];
        if (format == "csv") {
          ASSERT_EQ(r.kind, 's');
          const std::string& t = r.text[static_cast<std::size_t>(k)];
          if (x.kind == 'd') {
            const double v = std::strtod(t.c_str(), nullptr);
            if (std::isnan(x.real)) {
              EXPECT_EQ(t, "NaN");
            } else {
              EXPECT_EQ(v, x.real) << t;
            }
          } else if (x.kind == 'i') {
            EXPECT_EQ(std::stoll(t), x.integer);
          } else {
            EXPECT_EQ(t, x.text);
          }
          continue;
        }
        ASSERT_EQ(r.kind, x.kind);
        if (x.kind == 'd') {
          if (std::isnan(x.real)) {
            EXPECT_TRUE(std::isnan(r.real[static_cast<std::size_t>(k)]));
          } else {
            EXPECT_EQ(r.real[static_cast<std::size_t>(k)], x.real);
          }
        } else if (x.kind == 'i') {
          EXPECT_EQ(r.integer[static_cast<std::size_t>(k)], x.integer);
        } else {
          EXPECT_EQ(r.text[static_cast<std::size_t>(k)], x.text);
        }
      }
    }
  }

  ExportSummary Export(const std::string& out) {
    auto sink = OpenSink(out, false);
    ExportSummary s = ExportLog(log_, ExportOptions{}, *sink);
    sink->Close();
    return s;
  }

  std::filesystem::path dir_;
  std::string log_;
  std::vector<LcmStruct> structs_;
  std::vector<std::vector<std::vector<Expected>>> expected_;  // [type][message][column]
};

TEST_F(RoundTrip, Hdf5HoldsEveryFieldOfEveryType) {
  const std::string out = (dir_ / "all.h5").string();
  const ExportSummary s = Export(out);
  EXPECT_EQ(s.rows, static_cast<std::int64_t>(kMessages * structs_.size()));
  EXPECT_EQ(s.undecodable + s.unknown_type + s.outside_window, 0);
  for (std::size_t ti = 0; ti < structs_.size(); ++ti) {
    const auto read = test::ReadH5Table(out, "T_" + structs_[ti].name);
    Compare(ti, read, "h5");
    ASSERT_FALSE(read.empty());
    EXPECT_EQ(read[0].unit, "s");  // time
  }
}

TEST_F(RoundTrip, MatHoldsEveryFieldOfEveryType) {
  const std::string out = (dir_ / "all.mat").string();
  Export(out);
  EXPECT_EQ(test::MatVariables(out).size(), structs_.size() + 1);  // and the legend, rocklab_columns
  for (std::size_t ti = 0; ti < structs_.size(); ++ti) {
    Compare(ti, test::ReadMatTable(out, "T_" + structs_[ti].name), "mat");
  }
}

TEST_F(RoundTrip, CsvHoldsEveryFieldOfEveryType) {
  const std::string out = (dir_ / "all.csv").string();
  const ExportSummary s = Export(out);
  EXPECT_EQ(s.tables.size(), structs_.size());
  for (std::size_t ti = 0; ti < structs_.size(); ++ti) {
    Compare(ti, test::ReadCsvTable(CsvWriter::TablePath(out, "T_" + structs_[ti].name)), "csv");
  }
}

// Oracle: the window's definition (docs/export.md): seconds from the first
// message's utime; the messages above are 0.1 s apart per round.
TEST_F(RoundTrip, WindowAndChannelFilter) {
  const std::string out = (dir_ / "window.h5").string();
  auto sink = OpenSink(out, false);
  ExportOptions o;
  o.channels = "T_(table_state_t|raw_frame_t)";
  o.start_s = 0.05;
  o.end_s = 0.15;
  const ExportSummary s = ExportLog(log_, o, *sink);
  sink->Close();
  EXPECT_EQ(s.rows, 2);  // message k = 1 of each of the two channels
  EXPECT_EQ(s.outside_window, 4);
  EXPECT_EQ(s.filtered, static_cast<std::int64_t>(kMessages * (structs_.size() - 2)));
  EXPECT_EQ(test::H5Groups(out), (std::vector<std::string>{"T_raw_frame_t", "T_table_state_t"}));
}

}  // namespace
}  // namespace rocklab::exporter
