// Metadata kept on the way out, in every format (HDF5, MAT, CSV), read back
// with the libraries behind h5py/MATLAB (HDF5, libmatio) and a CSV parser:
// - a LabVIEW file's units (Y_Unit_Label), its Comment column and its empty
//   fields (counted as empty values, not as bad ones);
// - RL_RAW's columns named after RL_DAQ_CONFIG's channels, raw or calibrated;
// - the names of integer codes (kind, flags, regime, equations, accel_source):
//   a legend in every format, and a column kind_name for events.
// Oracles: the fixture text; the .lcm files' constants (parsed here, not
// taken from export/fields.cpp); gain * raw + offset evaluated here in
// double (the export evaluates the same expression: compared with ==).
#include <gtest/gtest.h>
#include <hdf5.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>

#include "common/lcm_log.h"
#include "export/csv_writer.h"
#include "export/export.h"
#include "export/fields.h"
#include "export/info.h"
#include "rocklab/block_state2_t.hpp"
#include "rocklab/block_state_t.hpp"
#include "rocklab/daq_config_t.hpp"
#include "rocklab/event_t.hpp"
#include "rocklab/model_state2_t.hpp"
#include "rocklab/model_state4_t.hpp"
#include "rocklab/raw_frame_t.hpp"
#include "rocklab/table_state_t.hpp"
#include "tests/export/readback.h"
#include "tests/scratch.h"

namespace rocklab::exporter {
namespace {

std::string MetadataDir() { return test::ScratchDir("metadata"); }

// As LabVIEW's Write To Measurement File writes a file (Date/Time lines,
// Y_Unit_Label among the segment keys, a trailing tab on header lines, a
// Comment column), with two empty fields and two comments, one with a comma
// and a non-ASCII character.
const char* kLabviewLvm =
    "LabVIEW Measurement\t\nWriter_Version\t2\nReader_Version\t2\nSeparator\tTab\nDecimal_Separator\t.\n"
    "Multi_Headings\tNo\nX_Columns\tOne\nTime_Pref\tRelative\nOperator\tlab\nDate\t2026/11/02\n"
    "Time\t14:03:21.5\n***End_of_Header***\t\n\n"
    "Channels\t3\t\nSamples\t4\t4\t4\t\nDate\t2026/11/02\t2026/11/02\t2026/11/02\t\n"
    "Time\t14:03:21.5\t14:03:21.5\t14:03:21.5\t\nY_Unit_Label\tmm\tVolts\tm/s^2\t\n"
    "X_Dimension\tTime\tTime\tTime\t\nX0\t0.0000000000000000E+0\t0.0000000000000000E+0\t0.0000000000000000E+0\t\n"
    "Delta_X\t0.001000\t0.001000\t0.001000\t\n***End_of_Header***\t\t\t\t\n"
    "X_Value\ttable_disp\tmirror_s\ttable_acc\tComment\n"
    "0.000000\t1.5\t2.25\t-0.5\tdrop started\n"
    "0.001000\t1.75\t\t0.25\n"
    "0.002000\t\t2.5\t0.125\t\n"
    "0.003000\t2\t2.75\t0\tsee log, \xc2\xb5m\n";

const std::vector<std::string> kExts = {".h5", ".mat", ".csv"};

bool Ends(const std::string& s, const std::string& e) {
  return s.size() >= e.size() && s.compare(s.size() - e.size(), e.size(), e) == 0;
}

// The table `table` of an export, by format (`single`: a raw file's CSV).
std::vector<test::ReadColumn> ReadTable(const std::string& out, const std::string& table, bool single) {
  if (Ends(out, ".h5")) return test::ReadH5Table(out, table);
  if (Ends(out, ".mat")) return test::ReadMatTable(out, table);
  return test::ReadCsvTable(single ? out : CsvWriter::TablePath(out, table));
}

const test::ReadColumn* Find(const std::vector<test::ReadColumn>& t, const std::string& name) {
  for (const auto& c : t) {
    if (c.name == name) return &c;
  }
  ADD_FAILURE() << "no column " << name;
  return nullptr;
}

double Real(const test::ReadColumn& c, std::size_t r) {
  return c.kind == 's' ? std::strtod(c.text.at(r).c_str(), nullptr) : c.real.at(r);
}
std::int64_t Int(const test::ReadColumn& c, std::size_t r) {
  return c.kind == 's' ? std::stoll(c.text.at(r)) : c.integer.at(r);
}

// What a format says about one column, in the legend's words.
struct Meta {
  std::string unit, codes, description;
};

Meta MetaOf(const std::string& out, const std::string& table, const std::string& column) {
  Meta m;
  if (Ends(out, ".h5")) {
    for (const auto& c : test::ReadH5Table(out, table)) {
      if (c.name != column) continue;
      m.unit = c.unit;
      m.description = c.description;
      EXPECT_EQ(c.code_values.size(), c.code_names.size());
      for (std::size_t k = 0; k < c.code_values.size() && k < c.code_names.size(); ++k) {
        if (k) m.codes += ';';
        m.codes += std::to_string(c.code_values[k]) + (c.code_kind == "bitmask" ? "|=" : "=") + c.code_names[k];
      }
      if (!c.code_values.empty()) {
        EXPECT_TRUE(c.code_kind == "enum" || c.code_kind == "bitmask") << c.code_kind;
      }
      return m;
    }
    ADD_FAILURE() << out << ": no " << table << "/" << column;
    return m;
  }
  const auto legend = Ends(out, ".mat") ? test::ReadMatTable(out, "rocklab_columns")
                                        : test::ReadCsvTable(CsvWriter::LegendPath(out));
  if (legend.size() != 5) {
    ADD_FAILURE() << out << ": the legend has " << legend.size() << " columns";
    return m;
  }
  EXPECT_EQ(legend[0].name, "table");
  EXPECT_EQ(legend[1].name, "column");
  EXPECT_EQ(legend[2].name, "unit");
  EXPECT_EQ(legend[3].name, "codes");
  EXPECT_EQ(legend[4].name, "description");
  for (std::size_t r = 0; r < legend[0].text.size(); ++r) {
    if (legend[0].text[r] == table && legend[1].text[r] == column) {
      return {legend[2].text[r], legend[3].text[r], legend[4].text[r]};
    }
  }
  ADD_FAILURE() << out << ": the legend has no row for " << table << "." << column;
  return m;
}

std::string Export(const std::string& in, const std::string& out, const ExportOptions& o, bool log,
                   ExportSummary* summary = nullptr, std::vector<std::string>* problems = nullptr) {
  auto sink = OpenSink(out, !log);
  auto on_problem = [problems](const std::string& p) {
    if (problems) problems->push_back(p);
  };
  const ExportSummary s = log ? ExportLog(in, o, *sink, on_problem) : ExportRaw(in, o, *sink, on_problem);
  sink->Close();
  if (summary) *summary = s;
  return out;
}

// ---- point 1: LabVIEW units, comments, empty fields ---------------------------

TEST(LvmMetadata, UnitsCommentsAndEmptyValuesReachEveryFormat) {
  const std::string lvm = MetadataDir() + "/labview.lvm";
  std::ofstream(lvm, std::ios::binary) << kLabviewLvm;
  const double nan = std::nan("");
  const std::vector<std::vector<double>> want = {{1.5, 1.75, nan, 2}, {2.25, nan, 2.5, 2.75}, {-0.5, 0.25, 0.125, 0}};
  const std::vector<std::string> comments = {"drop started", "", "", "see log, \xc2\xb5m"};
  for (const std::string& ext : kExts) {
    SCOPED_TRACE(ext);
    ExportSummary s;
    const std::string out = Export(lvm, MetadataDir() + "/labview" + ext, ExportOptions{}, false, &s);
    EXPECT_EQ(s.rows, 4);
    EXPECT_EQ(s.empty_values, 2);
    EXPECT_EQ(s.bad_values, 0);
    EXPECT_EQ(s.comments, 2);
    const auto t = ReadTable(out, "data", true);
    ASSERT_EQ(t.size(), 5u);
    const std::vector<std::string> names = {"time", "table_disp", "mirror_s", "table_acc", "comment"};
    for (std::size_t c = 0; c < names.size(); ++c) EXPECT_EQ(t[c].name, names[c]);
    for (std::size_t c = 0; c < 3; ++c) {
      for (std::size_t r = 0; r < 4; ++r) {
        const double got = Real(t[c + 1], r);
        if (std::isnan(want[c][r])) {
          EXPECT_TRUE(std::isnan(got)) << names[c + 1] << " row " << r;
        } else {
          EXPECT_EQ(got, want[c][r]) << names[c + 1] << " row " << r;
        }
      }
    }
    EXPECT_EQ(t[4].text, comments);
    EXPECT_EQ(MetaOf(out, "data", "table_disp").unit, "mm");
    EXPECT_EQ(MetaOf(out, "data", "mirror_s").unit, "Volts");
    EXPECT_EQ(MetaOf(out, "data", "table_acc").unit, "m/s^2");
    EXPECT_EQ(MetaOf(out, "data", "time").unit, "s");
    EXPECT_NE(MetaOf(out, "data", "comment").description.find("Comment"), std::string::npos);
  }
}

// The rig's unit fills in where the file states none; the file's wins.
TEST(LvmMetadata, TheFilesUnitWinsOverTheRigs) {
  const std::string lvm = MetadataDir() + "/labview_rig.lvm";
  std::ofstream(lvm, std::ios::binary) << kLabviewLvm;
  ExportOptions o;
  o.units = {{"table_disp", "m"}};
  const std::string out = Export(lvm, MetadataDir() + "/labview_rig.h5", o, false);
  const Meta m = MetaOf(out, "data", "table_disp");
  EXPECT_EQ(m.unit, "mm");
  EXPECT_NE(m.description.find("the rig calibrates them to m"), std::string::npos) << m.description;
}

TEST(LvmMetadata, InfoShowsTheFilesUnitsAndCounts) {
  const std::string lvm = MetadataDir() + "/labview_info.lvm";
  std::ofstream(lvm, std::ios::binary) << kLabviewLvm;
  const RawInfo info = ReadRawInfo(lvm, 0, {{"table_disp", "m"}});
  EXPECT_EQ(info.file_units, (std::vector<std::string>{"mm", "Volts", "m/s^2"}));
  EXPECT_EQ(info.units, (std::vector<std::string>{"mm", "Volts", "m/s^2"}));
  EXPECT_EQ(info.rig_units, (std::vector<std::string>{"m", "", ""}));
  EXPECT_EQ(info.empty_values, 2);
  EXPECT_EQ(info.bad_values, 0);
  EXPECT_EQ(info.comments, 2);
  const std::string text = ToText(info);
  EXPECT_NE(text.find("table_disp  [mm, from the file; the rig calibrates to m]"), std::string::npos) << text;
  EXPECT_NE(text.find("mirror_s  [Volts, from the file]"), std::string::npos) << text;
  EXPECT_NE(text.find("2 empty values read as NaN"), std::string::npos) << text;
  const nlohmann::json j = ToJson(info);
  EXPECT_EQ(j["empty_values"], 2);
  EXPECT_EQ(j["comments"], 2);
  EXPECT_EQ(j["channels"][0]["file_unit"], "mm");
  EXPECT_EQ(j["channels"][0]["rig_unit"], "m");
  EXPECT_EQ(j["channels"][0]["unit"], "mm");
  EXPECT_TRUE(j["channels"][1]["rig_unit"].is_null());
}

// ---- a log ---------------------------------------------------------------------

template <class Msg>
void PutMessage(common::LogWriter& w, const std::string& channel, const Msg& m) {
  std::vector<std::uint8_t> buf(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(buf.data(), 0, static_cast<int>(buf.size()));
  ASSERT_TRUE(w.Write(channel, buf.data(), buf.size(), m.utime));
}

rocklab::daq_config_t Config() {
  rocklab::daq_config_t c{};
  c.utime = 0;
  c.rig_name = "rig-a";
  c.calibration_id = "cal-1";
  c.sample_rate_hz = 1000;
  c.num_channels = 3;
  c.channel_names = {"mirror_s", "table_disp", "time"};  // "time" collides with the time column
  c.channel_units = {"m", "m", "s"};
  c.channel_sensors = {"mirror.s", "table.displacement", ""};
  c.gain = {0.001, 2.5, 1};
  c.offset = {0.5, -1, 0};
  c.alpha = 0.2;
  c.p = 3;
  c.mu = 0.9;
  return c;
}

const std::vector<std::vector<double>> kRaw = {{100, 3, 7}, {250.5, -0.125, 8}};

// RL_DAQ_CONFIG, two RL_RAW frames, and one message of each type with codes.
std::string WriteLog(const std::string& name, bool config_first) {
  const std::string path = MetadataDir() + "/" + name;
  common::LogWriter w(path);
  if (config_first) PutMessage(w, "RL_DAQ_CONFIG", Config());
  for (std::size_t k = 0; k < kRaw.size(); ++k) {
    rocklab::raw_frame_t f{};
    f.utime = static_cast<std::int64_t>(1000 * k);
    f.seq = static_cast<std::int64_t>(k);
    f.num_channels = 3;
    f.values = kRaw[k];
    PutMessage(w, "RL_RAW", f);
  }
  rocklab::event_t e{};
  e.utime = 1000;
  e.source = "daq";
  e.kind = rocklab::event_t::IMPACT;
  PutMessage(w, "RL_EVENT", e);
  e.utime = 2000;
  e.kind = 99;  // a code no constant names
  PutMessage(w, "RL_EVENT", e);
  rocklab::block_state_t b{};
  b.utime = 1000;
  b.flags = rocklab::block_state_t::FLAG_SLIDING | rocklab::block_state_t::FLAG_NO_MIRROR | 128;
  PutMessage(w, "RL_THETA", b);
  b.utime = 2000;
  b.flags = 0;
  PutMessage(w, "RL_THETA", b);
  rocklab::model_state2_t m{};
  m.utime = 1000;
  m.name = "housner";
  m.model = "housner";
  m.regime = rocklab::model_state2_t::REGIME_ROCKING;
  m.equations = rocklab::model_state2_t::EQUATIONS_EQ10;
  PutMessage(w, "RL_MODEL_housner", m);
  rocklab::table_state_t t{};
  t.utime = 1000;
  t.accel_source = rocklab::table_state_t::ACCEL_EXACT;
  PutMessage(w, "RL_TABLE", t);
  if (!config_first) PutMessage(w, "RL_DAQ_CONFIG", Config());
  EXPECT_TRUE(w.Close());
  return path;
}

// ---- point 3: codes by name --------------------------------------------------------

TEST(LogMetadata, CodesHaveTheirNamesInEveryFormat) {
  const std::string log = WriteLog("codes.lcm", true);
  for (const std::string& ext : kExts) {
    SCOPED_TRACE(ext);
    const std::string out = Export(log, MetadataDir() + "/codes" + ext, ExportOptions{}, true);
    const auto event = ReadTable(out, "RL_EVENT", false);
    const test::ReadColumn* kind = Find(event, "kind");
    const test::ReadColumn* kind_name = Find(event, "kind_name");
    ASSERT_TRUE(kind && kind_name);
    EXPECT_EQ(Int(*kind, 0), static_cast<std::int64_t>(rocklab::event_t::IMPACT));
    EXPECT_EQ(kind_name->text, (std::vector<std::string>{"IMPACT", "99"}));
    // The name columns follow the fields: the fields keep their positions.
    EXPECT_EQ(event.back().name, "kind_name");
    const Meta km = MetaOf(out, "RL_EVENT", "kind");
    EXPECT_NE(km.codes.find("1=UPLIFT;2=IMPACT;"), std::string::npos) << km.codes;
    EXPECT_NE(km.codes.find("14=COMMENT"), std::string::npos) << km.codes;

    // The 1 kHz code fields: the legend only (no text column per row).
    const auto theta = ReadTable(out, "RL_THETA", false);
    EXPECT_EQ(theta.back().name, "flags");
    EXPECT_EQ(MetaOf(out, "RL_THETA", "flags").codes,
              "1|=SLIDING;2|=JUMP;4|=TWIST;8|=OUT_OF_PLANE;16|=DISAGREE;32|=NO_MIRROR;64|=NO_CAMERA");
    const auto model = ReadTable(out, "RL_MODEL_housner", false);
    EXPECT_EQ(model.back().name, "equations");
    const test::ReadColumn* regime = Find(model, "regime");
    ASSERT_TRUE(regime);
    EXPECT_EQ(Int(*regime, 0), static_cast<std::int64_t>(rocklab::model_state2_t::REGIME_ROCKING));
    EXPECT_EQ(MetaOf(out, "RL_MODEL_housner", "regime").codes, "0=REST;1=ROCKING;2=OVERTURNED");
    EXPECT_EQ(MetaOf(out, "RL_MODEL_housner", "equations").codes, "-1=UNKNOWN;0=HOUSNER;1=EQ10;2=LIMIT");
    EXPECT_EQ(MetaOf(out, "RL_TABLE", "accel_source").codes, "0=ACCELEROMETER;1=DIFFERENTIATED;2=EXACT");
  }
}

// The per-body types (issue 37): each body's code column carries its
// field's legend and unit, in every format. Oracle: the messages made here
// and the .lcm constants.
TEST(LogMetadata, PerBodyCodeColumnsCarryTheirFieldsLegend) {
  const std::string log = MetadataDir() + "/bodies.lcm";
  {
    common::LogWriter w(log);
    rocklab::block_state2_t b{};
    b.utime = 1000;
    b.nbodies = 2;
    b.theta = {0.01, -0.02};
    b.theta_dot = b.theta_mirror = b.theta_camera = b.sliding = b.jump = b.twist = b.out_of_plane = b.theta;
    b.leds_used = {4, 3};
    b.flags = {0, rocklab::block_state2_t::FLAG_JUMP | rocklab::block_state2_t::FLAG_NO_CAMERA};
    PutMessage(w, "RL_THETA", b);
    rocklab::model_state4_t m{};
    m.utime = 1000;
    m.name = "stack";
    m.model = "housner";
    m.nbodies = 2;
    m.theta = m.theta_dot = m.chi = m.psi = m.alpha = m.p = m.mu = {0.5, 1.5};
    m.regime = {rocklab::model_state4_t::REGIME_REST, rocklab::model_state4_t::REGIME_OVERTURNED};
    m.mode = "lower-alone";
    PutMessage(w, "RL_MODEL_stack", m);
    EXPECT_TRUE(w.Close());
  }
  for (const std::string& ext : kExts) {
    SCOPED_TRACE(ext);
    const std::string out = Export(log, MetadataDir() + "/bodies" + ext, ExportOptions{}, true);
    const auto theta = ReadTable(out, "RL_THETA", false);
    const test::ReadColumn* flags = Find(theta, "flags_1");
    ASSERT_TRUE(flags);
    EXPECT_EQ(Int(*flags, 0), 2 + 64);
    for (const char* column : {"flags_0", "flags_1"}) {
      EXPECT_EQ(MetaOf(out, "RL_THETA", column).codes,
                "1|=SLIDING;2|=JUMP;4|=TWIST;8|=OUT_OF_PLANE;16|=DISAGREE;32|=NO_MIRROR;64|=NO_CAMERA");
    }
    EXPECT_EQ(MetaOf(out, "RL_THETA", "leds_used_1").codes, "");
    EXPECT_EQ(MetaOf(out, "RL_THETA", "theta_dot_1").unit, "rad/s");
    const auto model = ReadTable(out, "RL_MODEL_stack", false);
    const test::ReadColumn* regime = Find(model, "regime_1");
    ASSERT_TRUE(regime);
    EXPECT_EQ(Int(*regime, 0), static_cast<std::int64_t>(rocklab::model_state4_t::REGIME_OVERTURNED));
    EXPECT_EQ(MetaOf(out, "RL_MODEL_stack", "regime_0").codes, "0=REST;1=ROCKING;2=OVERTURNED");
    EXPECT_EQ(MetaOf(out, "RL_MODEL_stack", "equations").codes, "-1=UNKNOWN;0=HOUSNER;1=EQ10;2=LIMIT");
    EXPECT_EQ(model.back().name, "mode");
  }
}

// Every constant of every .lcm file has a legend under a field of its type
// (so a new constant, or a new code field, cannot be exported as a bare
// integer unnoticed). Oracle: the .lcm text.
TEST(LogMetadata, EveryLcmConstantIsNamedInALegend) {
  // A scalar or a per-body array (block_state2_t's flags[nbodies]).
  const std::regex field(R"(^\s*(u?int(8|16|32|64)_t|boolean)\s+(\w+)\s*(\[\s*\w+\s*\])?\s*;)");
  const std::regex constant(R"(^\s*const\s+\w+\s+(\w+)\s*=\s*(-?\d+)\s*;)");
  int constants = 0;
  for (const auto& entry : std::filesystem::directory_iterator(ROCKLAB_SOURCE_DIR "/lcm_types")) {
    if (entry.path().extension() != ".lcm") continue;
    std::ifstream in(entry.path());
    std::vector<std::string> fields;
    std::vector<std::pair<std::string, std::int64_t>> consts;
    std::string line;
    while (std::getline(in, line)) {
      std::smatch m;
      if (std::regex_search(line, m, field)) fields.push_back(m[3]);
      if (std::regex_search(line, m, constant)) consts.emplace_back(m[1], std::stoll(m[2]));
    }
    for (const auto& [name, value] : consts) {
      ++constants;
      bool named = false;
      for (const std::string& f : fields) {
        const std::vector<Code>* codes = FieldCodes(f);
        if (!codes) continue;
        for (const Code& c : *codes) {
          // FLAG_SLIDING -> SLIDING, REGIME_REST -> REST, IMPACT -> IMPACT.
          const bool same = name == c.name || (Ends(name, "_" + c.name) && name.find('_') == name.size() - c.name.size() - 1);
          named = named || (same && c.value == value);
        }
      }
      EXPECT_TRUE(named) << entry.path().filename() << ": constant " << name << " = " << value
                         << " has no legend (export/fields.cpp: Legends)";
    }
  }
  EXPECT_GE(constants, 30);
}

// ---- point 2: RL_RAW by channel ------------------------------------------------------

TEST(LogMetadata, RawColumnsAreNamedAfterTheRigsChannelsRawByDefault) {
  const std::string log = WriteLog("raw.lcm", true);
  const rocklab::daq_config_t config = Config();
  for (const bool calibrated : {false, true}) {
    for (const std::string& ext : kExts) {
      SCOPED_TRACE(ext + (calibrated ? " calibrated" : " raw"));
      ExportOptions o;
      o.calibrated = calibrated;
      const std::string out =
          Export(log, MetadataDir() + "/raw" + std::string(calibrated ? "_cal" : "") + ext, o, true);
      const auto raw = ReadTable(out, "RL_RAW", false);
      // values_0.. as before (the old names stay), then the channels.
      const std::vector<std::string> names = {"time", "utime", "seq", "num_channels", "values_0", "values_1",
                                              "values_2", "mirror_s", "table_disp", "channel_time"};
      ASSERT_EQ(raw.size(), names.size());
      for (std::size_t c = 0; c < names.size(); ++c) EXPECT_EQ(raw[c].name, names[c]);
      for (std::size_t r = 0; r < kRaw.size(); ++r) {
        for (std::size_t k = 0; k < 3; ++k) {
          EXPECT_EQ(Real(raw[4 + k], r), kRaw[r][k]);
          const double want = calibrated ? config.gain[k] * kRaw[r][k] + config.offset[k] : kRaw[r][k];
          EXPECT_EQ(Real(raw[7 + k], r), want) << names[7 + k] << " row " << r;
        }
      }
      const Meta v0 = MetaOf(out, "RL_RAW", "values_0");
      EXPECT_NE(v0.description.find("channel mirror_s (sensor mirror.s), raw; physical = gain * raw + offset in m, "
                                    "gain 0.001, offset 0.5"),
                std::string::npos)
          << v0.description;
      const Meta named = MetaOf(out, "RL_RAW", "table_disp");
      EXPECT_EQ(named.unit, calibrated ? "m" : "");
      // HDF5, raw: table_disp is a second link to values_1's dataset, so
      // it has values_1's description.
      const std::string want = calibrated ? "calibrated from values_1"
                               : ext == ".h5" ? "channel table_disp (sensor table.displacement), raw;"
                                              : "raw (= values_1)";
      EXPECT_NE(named.description.find(want), std::string::npos) << named.description;
    }
  }
}

// HDF5, raw: a channel's column is a second name of values_k's dataset,
// not a copy (calibrated: its own dataset). Oracle: the objects' addresses.
TEST(LogMetadata, Hdf5RawChannelColumnsAreLinksNotCopies) {
  const std::string log = WriteLog("raw_links.lcm", true);
  for (const bool calibrated : {false, true}) {
    ExportOptions o;
    o.calibrated = calibrated;
    const std::string out = Export(log, MetadataDir() + (calibrated ? "/links_cal.h5" : "/links.h5"), o, true);
    hid_t f = H5Fopen(out.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
    ASSERT_GE(f, 0);
    H5O_info_t a{}, b{};
    ASSERT_GE(H5Oget_info_by_name2(f, "RL_RAW/values_1", &a, H5O_INFO_BASIC, H5P_DEFAULT), 0);
    ASSERT_GE(H5Oget_info_by_name2(f, "RL_RAW/table_disp", &b, H5O_INFO_BASIC, H5P_DEFAULT), 0);
    EXPECT_EQ(a.addr == b.addr, !calibrated);
    EXPECT_EQ(a.rc, calibrated ? 1u : 2u);
    H5Fclose(f);
  }
}

// Channel names that cannot be column names as they are: '/' (an HDF5
// path) becomes '_'; a name a field already has gets `channel_`.
TEST(LogMetadata, RawChannelNamesAreMadeSafeColumnNames) {
  const std::string path = MetadataDir() + "/odd_names.lcm";
  {
    common::LogWriter w(path);
    rocklab::daq_config_t c = Config();
    c.num_channels = 2;
    c.channel_names = {"a/b", "values_0"};
    c.channel_units = {"m", "m"};
    c.channel_sensors = {"", ""};
    c.gain = {1, 1};
    c.offset = {0, 0};
    PutMessage(w, "RL_DAQ_CONFIG", c);
    rocklab::raw_frame_t f{};
    f.num_channels = 2;
    f.values = {1, 2};
    PutMessage(w, "RL_RAW", f);
    ASSERT_TRUE(w.Close());
  }
  for (const std::string& ext : kExts) {
    const std::string out = Export(path, MetadataDir() + "/odd_names" + ext, ExportOptions{}, true);
    const auto raw = ReadTable(out, "RL_RAW", false);
    ASSERT_EQ(raw.size(), 8u) << ext;
    EXPECT_EQ(raw[6].name, "a_b") << ext;
    EXPECT_EQ(raw[7].name, "channel_values_0") << ext;
    EXPECT_EQ(Real(raw[7], 0), 2.0) << ext;
  }
}

// A raw frame before any RL_DAQ_CONFIG: nothing to name the columns after;
// they stay values_N and the export says why.
TEST(LogMetadata, RawBeforeAnyConfigStaysUnnamedAndSaysSo) {
  const std::string log = WriteLog("raw_late_config.lcm", false);
  std::vector<std::string> problems;
  const std::string out = Export(log, MetadataDir() + "/raw_late.h5", ExportOptions{}, true, nullptr, &problems);
  const auto raw = ReadTable(out, "RL_RAW", false);
  ASSERT_EQ(raw.size(), 7u);
  EXPECT_EQ(raw.back().name, "values_2");
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_NE(problems[0].find("no daq_config_t (RL_DAQ_CONFIG) before the first raw frame"), std::string::npos)
      << problems[0];
}

}  // namespace
}  // namespace rocklab::exporter
