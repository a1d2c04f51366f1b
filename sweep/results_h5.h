#pragma once
/// @file
/// A sweep's results from the HDF5 file `rocklab sweep --out FILE.h5`
/// writes (row_writer.h: group /results, a 1-D dataset per column).

#include <cstdint>
#include <string>
#include <vector>

#include "sweep/plot.h"

namespace rocklab::sweep {

/// True when `path` starts with the HDF5 signature (\x89HDF\r\n\x1a\n).
bool IsHdf5File(const std::string& path);

/// The rows of /results (the columns ResultRow holds; others are ignored).
/// @throws std::runtime_error "FILE: ..." naming a missing group or column,
///   columns of different lengths, a wrong type or a value ReadResults
///   would refuse in a CSV (with its row number, from 1).
std::vector<ResultRow> ReadResultsH5(const std::string& path);

/// One dataset of /results as the file holds it.
struct H5ResultsColumn {
  std::string name;
  /// 'd' a float dataset (read as double), 'i' an integer one (as int64),
  /// 's' variable-length strings, '?' anything else (not read).
  char kind{};
  std::vector<double> real;
  std::vector<std::int64_t> integer;
  std::vector<std::string> text;
  std::size_t size() const { return kind == 'd' ? real.size() : kind == 'i' ? integer.size() : text.size(); }
};

/// Every 1-D dataset of /results with its values, in name order (for
/// `sweep --merge`, which checks them against Header()).
/// @throws std::runtime_error "FILE: ..." naming a missing group, a dataset
///   that is not 1-D or that cannot be read.
std::vector<H5ResultsColumn> ReadResultsColumnsH5(const std::string& path);

}  // namespace rocklab::sweep
