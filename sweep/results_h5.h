#pragma once
/// @file
/// A sweep's results from the HDF5 file `rocklab sweep --out FILE.h5`
/// writes (row_writer.h: group /results, a 1-D dataset per column).

#include <cstdint>
#include <string>
#include <vector>

#include "sweep/plot.h"
#include "sweep/sweep.h"

namespace rocklab::sweep {

/// True when `path` starts with the HDF5 signature (\x89HDF\r\n\x1a\n).
bool IsHdf5File(const std::string& path);

/// The rows of /results (the columns ResultRow holds; others are ignored).
/// @throws std::runtime_error "FILE: ..." naming a missing group or column,
///   columns of different lengths, a wrong type or a value ReadResults
///   would refuse in a CSV (with its row number, from 1).
std::vector<ResultRow> ReadResultsH5(const std::string& path);

/// Each dataset is checked before anything is allocated for it: 1-D, its
/// rows at most the file's size / kMinFileBytesPerRow (a sweep's row holds
/// three strings, each a global-heap object of at least 24 bytes in the
/// file, however the numbers compress), stored in the file (no external or
/// virtual storage), chunks of at most kMaxChunkBytes, numbers of at most 8
/// bytes, strings adding up to at most the file's size. So what a reader
/// holds is bounded by a multiple of the file's size (docs/sweep.md,
/// "Damaged and hostile shards"), and a file declaring 2^27 rows in 8 KB is
/// an error naming the file and dataset. Datasets and attributes are opened
/// by name; the group's links are never iterated (H5Literate).
/// libhdf5 itself crashes on some damaged files (its metadata reads overrun
/// buffers, whatever is asked of it), so both readers below run libhdf5 in
/// a forked child that sends back what it read: a damaged file is an error
/// naming it ("a damaged HDF5 file: libhdf5 failed reading it (its reader
/// ended by signal 11)"), never a crash of the command.
inline constexpr unsigned long long kMinFileBytesPerRow = 16;
inline constexpr unsigned long long kMaxChunkBytes = 1ULL << 20;

/// One dataset of /results as the file holds it.
struct H5ResultsColumn {
  std::string name;
  /// 'd' a float dataset (read as double), 'i' an integer one (as int64),
  /// 's' variable-length strings, '?' anything else (not read), 0 when
  /// /results has no such dataset.
  char kind{};
  std::vector<double> real;
  std::vector<std::int64_t> integer;
  std::vector<std::string> text;
  std::size_t size() const { return kind == 'd' ? real.size() : kind == 'i' ? integer.size() : text.size(); }
};

/// The datasets of /results `sweep --merge` reads, and the file's definition.
struct H5ResultsTable {
  std::vector<H5ResultsColumn> columns;  ///< one per name asked for, in that order
  std::size_t links{};                   ///< links in /results (H5Gget_info: counted, not listed)
  Definition definition;                 ///< the root attributes sweep_* (empty: an older rocklab's file)
};

/// The datasets `names` of /results with their values, and the definition.
/// @throws std::runtime_error "FILE: ..." naming a missing group, a dataset
///   that fails the checks above or that cannot be read.
H5ResultsTable ReadResultsTableH5(const std::string& path, const std::vector<std::string>& names);

}  // namespace rocklab::sweep
