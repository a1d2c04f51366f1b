#pragma once
// Which file formats each kind of data comes in, and which command options
// read that kind: one table, so that the help texts name every format and
// the command x format test (tests/tools/formats_test.cpp) walks every
// reader over every format. A new format is one line in kFormats; the test
// then fails for each reader that does not take it, and each help text
// that does not name it. (docs/commands.md, "Formats", is this table.)
#include <string>
#include <string_view>

namespace rocklab::tools {

/// The kinds of data rocklab commands read from files.
enum class DataKind {
  kGroundMotion,  ///< table acceleration against time (a record)
  kSweepResults,  ///< the rows of `rocklab sweep`
};

/// One format of one kind of data.
struct DataFormat {
  DataKind kind;
  const char* name;       ///< how the help text names it (the test looks for this text)
  const char* extension;  ///< the file name ending that selects it ("" when read by content)
  const char* what;       ///< units and layout, for docs/commands.md
};

inline constexpr DataFormat kFormats[] = {
    {DataKind::kGroundMotion, "time,accel CSV", ".csv", "header time,accel; s, m/s^2"},
    {DataKind::kGroundMotion, "PEER NGA .AT2", ".AT2",
     "4 header lines, NPTS and DT, values in g, converted with g = 9.81 m/s^2"},
    {DataKind::kSweepResults, "CSV", ".csv", "`rocklab sweep --out FILE.csv`: one row per case, docs/sweep.md"},
    {DataKind::kSweepResults, "HDF5", ".h5",
     "`rocklab sweep --out FILE.h5` (or .hdf5): table /results, a dataset per column"},
};

/// A command option (or positional argument) that reads a kind of data.
struct DataReader {
  const char* command;  ///< the subcommand
  const char* option;   ///< "--accel", or the positional's name
  DataKind kind;
};

inline constexpr DataReader kReaders[] = {
    {"simulate", "--accel", DataKind::kGroundMotion},
    {"synth", "--accel", DataKind::kGroundMotion},
    {"fit", "--accel", DataKind::kGroundMotion},
    {"sweep", "--records", DataKind::kGroundMotion},
    {"info", "input", DataKind::kGroundMotion},
    {"sweep-plot", "results", DataKind::kSweepResults},
    {"sweep", "--merge", DataKind::kSweepResults},
    {"info", "input", DataKind::kSweepResults},
};

/// "time,accel CSV (header time,accel; ...) or PEER NGA .AT2 (...)": every
/// format of `kind`, for a help text.
inline std::string FormatsHelp(DataKind kind) {
  std::string out;
  std::size_t n = 0, count = 0;
  for (const DataFormat& f : kFormats) count += f.kind == kind ? 1 : 0;
  for (const DataFormat& f : kFormats) {
    if (f.kind != kind) continue;
    out += n == 0 ? "" : (n + 1 == count ? " or " : ", ");
    out += std::string(f.name) + " (" + f.what + ")";
    ++n;
  }
  return out;
}

/// True when `path` ends with `ending`, ignoring ASCII case.
inline bool EndsWithNoCase(std::string_view path, std::string_view ending) {
  if (path.size() < ending.size()) return false;
  for (std::size_t i = 0; i < ending.size(); ++i) {
    char a = path[path.size() - ending.size() + i], b = ending[i];
    if (a >= 'A' && a <= 'Z') a = static_cast<char>(a - 'A' + 'a');
    if (b >= 'A' && b <= 'Z') b = static_cast<char>(b - 'A' + 'a');
    if (a != b) return false;
  }
  return true;
}

}  // namespace rocklab::tools
