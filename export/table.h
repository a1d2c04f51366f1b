#pragma once
/// @file
/// Tables of named columns, written row by row: what every export format
/// (CSV, MAT, HDF5) takes, and what `rocklab sweep` can write results with.
///
/// A row is three parallel vectors indexed by column: a column of type
/// kDouble reads `real[i]`, kInt reads `integer[i]`, kString reads `text[i]`;
/// the other two vectors' entries at i are ignored. A caller keeps one Row
/// per table and refills it, so appending allocates nothing per row once the
/// strings have grown to their length.

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace rocklab::exporter {

enum class ColumnType : std::uint8_t { kDouble, kInt, kString };

/// A named value of an integer column (an enumeration constant of an .lcm
/// type, or one bit of a bitmask).
struct Code {
  std::int64_t value{};
  std::string name;  ///< the constant's name without its prefix ("IMPACT", "SLIDING")
};

struct Column {
  Column() = default;
  /// What every table gives: its name, type and unit (the metadata below
  /// set where there is some).
  Column(std::string name_, ColumnType type_ = ColumnType::kDouble, std::string unit_ = {})
      : name(std::move(name_)), type(type_), unit(std::move(unit_)) {}
  std::string name;  ///< UTF-8; unique within its table
  ColumnType type{ColumnType::kDouble};
  std::string unit;  ///< SI unit ("s", "rad", "m/s^2"), "1" dimensionless, "" none (counts, text)
  // Metadata beside the values (HDF5: attributes of the dataset; CSV and
  // MAT: the legend table, see LegendColumns). Empty: none.
  std::string description;  ///< one line: what the column holds where its name does not say
  std::vector<Code> codes;  ///< integer columns: the named values
  bool bitmask{false};      ///< codes are bits; a value is the OR of several
  /// The name of an earlier column of the table that always holds the same
  /// values (the caller fills both): HDF5 makes this column a second link
  /// to that dataset (no second copy; it shares its attributes); the other
  /// formats write it again.
  std::string same_as;
};


struct Row {
  std::vector<double> real;
  std::vector<std::int64_t> integer;
  std::vector<std::string> text;
  /// Sizes the three vectors to `columns` entries.
  void Resize(std::size_t columns) {
    real.resize(columns);
    integer.resize(columns);
    text.resize(columns);
  }
};

/// The legend of a set of tables: one row per column of every table, for
/// formats without per-column attributes (CSV: a file STEM.columns.csv;
/// MAT: a struct variable `rocklab_columns`). Columns: table, column, unit,
/// codes ("1=UPLIFT;2=IMPACT", bits "1|=SLIDING;2|=JUMP"), description.
std::vector<Column> LegendColumns();
/// The codes of `c` as the legend writes them ("" when it has none).
std::string CodesText(const Column& c);
/// Appends the legend rows of table `table`'s `columns` to `rows`.
void AppendLegendRows(const std::string& table, const std::vector<Column>& columns, std::vector<Row>& rows);

/// Where tables go. Tables may be added at any time; rows of different
/// tables may interleave. Errors of the file (cannot create, disk full)
/// throw std::runtime_error naming the file: an export that cannot be
/// written stops.
class TableSink {
 public:
  virtual ~TableSink() = default;
  /// Starts a table named `name` (a channel name, "data", "results");
  /// returns its handle for Append. @throws std::runtime_error.
  virtual int AddTable(const std::string& name, const std::vector<Column>& columns) = 0;
  /// Appends one row (row vectors at least as long as the table's columns).
  virtual void Append(int table, const Row& row) = 0;
  /// A text attribute of a table (HDF5: an attribute of its group, e.g. the
  /// LCM type); formats without attributes ignore it.
  virtual void Describe(int /*table*/, const std::string& /*key*/, const std::string& /*value*/) {}
  /// A text attribute of the whole output (its provenance: common/provenance.h):
  /// HDF5: an attribute of the root group; MAT: a field of the struct
  /// variable `rocklab_provenance`; CSV: a row of the sidecar
  /// STEM.provenance.csv (key,value). Keys are unique.
  virtual void DescribeFile(const std::string& /*key*/, const std::string& /*value*/) {}
  /// Writes what is buffered, closes every file and gives each its name
  /// (written beside, renamed when complete: common::AtomicFile);
  /// idempotent. A sink destroyed without Close() renames nothing and
  /// removes what it wrote, so a failed export leaves the previous files.
  virtual void Close() = 0;
  /// The files written (for the command's summary).
  virtual std::vector<std::string> files() const = 0;
};

}  // namespace rocklab::exporter
