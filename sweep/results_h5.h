#pragma once
/// @file
/// A sweep's results from the HDF5 file `rocklab sweep --out FILE.h5`
/// writes (row_writer.h: group /results, a 1-D dataset per column).

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

}  // namespace rocklab::sweep
