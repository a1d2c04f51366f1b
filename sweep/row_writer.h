#pragma once
/// @file
/// Where a sweep's rows go. The runner hands each case's outcome to a
/// RowWriter in case order; the writer formats and stores it. The CSV writer
/// and the HDF5 table (export's H5Writer: a table "results" with a dataset
/// per column and its unit) are chosen at OpenRowWriter by the extension.

#include <cstddef>
#include <memory>
#include <string>

#include "export/table.h"
#include "sweep/sweep.h"

namespace rocklab::exporter {
class H5Writer;
}

namespace rocklab::sweep {

/// The cases one run writes, in order: first, first + stride, ... below the
/// plan's size (a shard I/N is {I, N}; the whole sweep {0, 1}).
struct Slice {
  std::size_t first{0};
  std::size_t stride{1};
  std::size_t plan_size{0};
  /// How many cases the slice holds.
  std::size_t count() const { return first >= plan_size ? 0 : (plan_size - first + stride - 1) / stride; }
  /// The case index of the slice's k-th case.
  std::size_t index(std::size_t k) const { return first + k * stride; }
};

/// Takes the rows of a slice in order. Writes each row through to the file
/// (an interrupted sweep keeps every row written and resumes after them);
/// the file gets its name only at Close(), complete.
class RowWriter {
 public:
  virtual ~RowWriter() = default;
  /// How many of the slice's rows were already in the output (--resume), 0
  /// otherwise; the next Write is the slice's case rows_done().
  virtual std::size_t rows_done() const = 0;
  /// Appends case `index`'s row.
  /// @throws std::runtime_error naming the file on a write error.
  virtual void Write(std::size_t index, const Outcome& outcome) = 0;
  /// Flushes and closes. @throws std::runtime_error naming the file.
  virtual void Close() = 0;
};

/// The columns of Header() as the HDF5 table holds them, in order: each
/// with its type (the numbers kDouble, overturned and impacts kInt, record,
/// model and block kString) and unit.
const std::vector<exporter::Column>& ResultColumns();
/// The columns of HeaderOf(plan): ResultColumns(), and for an assembly
/// first_overturned_body (kString) and peak_abs_theta_K (kDouble, rad).
std::vector<exporter::Column> ResultColumnsOf(const Plan& plan);

/// The root attributes of a sweep's HDF5 file that hold its definition:
/// kH5DefinitionPrefix + key, one string each, and kH5DefinitionKeys, the
/// keys in order separated by spaces (read by name: the reader never lists
/// the file's attributes).
inline constexpr const char* kH5DefinitionPrefix = "sweep_";
inline constexpr const char* kH5DefinitionKeys = "sweep_definition_keys";

/// The HDF5 file of a sweep (what OpenRowWriter writes for an .h5): table
/// "results" of ResultColumns(), the root attribute columns_as_csv and the
/// definition's attributes (none when `definition` is empty), written
/// beside `path` and renamed at Close() (export's H5Writer). The one HDF5
/// table writer of the sweep: RowWriter and --merge append here.
class H5Results {
 public:
  /// @throws pipeline::OptionError "--out: ..." when the file cannot be made.
  /// `provenance`: root attributes with its keys (as `export` writes them).
  H5Results(const std::string& path, const Definition& definition, const ProvenanceLines& provenance = {});
  /// The same with the columns of `plan` (ResultColumnsOf: an assembly's
  /// sweep has more).
  H5Results(const std::string& path, const Plan& plan, const Definition& definition,
            const ProvenanceLines& provenance = {});
  ~H5Results();
  H5Results(const H5Results&) = delete;
  H5Results& operator=(const H5Results&) = delete;
  /// Appends a row: its cells by ResultColumns()' index and type (an empty
  /// CSV field, a value that is not there, is NaN in a kDouble column).
  void Append(const exporter::Row& row);
  void Close();

 private:
  void Open(const std::string& path, const std::vector<exporter::Column>& columns, const std::string& header,
            const Definition& definition, const ProvenanceLines& provenance);
  std::unique_ptr<exporter::H5Writer> writer_;
  int table_{};
};

/// Where a CSV sweep writes its rows until Close() renames the file to
/// `out`: `out` + ".partial", beside it (kept when the sweep stops early,
/// for --resume).
std::string PartialPath(const std::string& out);

/// Opens the output for `slice` of `plan`: `.csv` (or any other name) is a
/// CSV with Header(), written to PartialPath(path) and renamed to `path` at
/// Close(); `.h5`/`.hdf5` the same columns in an HDF5 table, written beside
/// and renamed at Close() (an empty CSV field is NaN there; --resume works
/// on a .csv only). Until Close(), `path` keeps what it held.
/// With `resume`, the rows of PartialPath(path) (an interrupted run), else
/// of `path` (a finished one) are kept: the header and every complete row
/// that is the slice's next case (a torn last line, without its newline, is
/// cut and written again); a row that belongs elsewhere is an error.
/// @throws pipeline::OptionError naming --out (and FILE:LINE for a row
///   that does not belong) when the file cannot be used.
/// `provenance` goes after the definition (CSV: ProvenanceText; HDF5: root
/// attributes); a resumed CSV keeps the provenance of the run that began it.
std::unique_ptr<RowWriter> OpenRowWriter(const std::string& path, const Plan& plan, const Slice& slice,
                                         bool resume, const ProvenanceLines& provenance = {});

}  // namespace rocklab::sweep
