#pragma once
/// @file
/// HDF5 tables (the HDF5 C library): a group per table, a 1-D dataset per
/// column in the group, all of one length. Datasets are chunked and
/// extendible (maximum size unlimited): rows are gathered per column up to
/// `chunk_rows` and written a whole chunk at a time, with HDF5's chunk cache
/// off, so memory stays at about chunk_rows x (8 bytes, or a string) per
/// column however long the table grows.
///
/// Types: double columns 64-bit IEEE floats, integer columns 64-bit signed
/// integers, text columns variable-length UTF-8 strings. Each dataset has a
/// `units` attribute when its column has a unit, a `description` when it
/// has one, and integer columns with named values (an enumeration, a
/// bitmask) `code_values`, `code_names` and `code_kind` ("enum" or
/// "bitmask"); a column Column::same_as another is a second hard link to
/// that dataset; each group a `columns`
/// attribute (the column names in order; the group also tracks creation
/// order) and any Describe()d attributes. Names are UTF-8; `/` in a table
/// name becomes `_`. h5py, MATLAB's h5read and pandas (via h5py) read it.
///
/// Reusable for any results table (`rocklab sweep`): AddTable, Append rows,
/// Close.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "export/table.h"

namespace rocklab::exporter {

struct H5WriterOptions {
  std::int64_t chunk_rows{4096};  ///< rows per chunk; > 0
  int deflate_level{1};           ///< gzip level 0 (off) .. 9, with the shuffle filter when > 0
  /// @throws std::invalid_argument naming the option.
  void Validate() const;
};

class H5Writer final : public TableSink {
 public:
  /// Writes beside `path` (common::AtomicFile); Close() renames the
  /// complete file to `path`. Destroyed without Close(), the temporary is
  /// removed and `path` keeps what it held. @throws std::runtime_error
  /// naming the file.
  explicit H5Writer(const std::string& path, H5WriterOptions options = {});
  ~H5Writer() override;
  H5Writer(const H5Writer&) = delete;
  H5Writer& operator=(const H5Writer&) = delete;

  int AddTable(const std::string& name, const std::vector<Column>& columns) override;
  void Append(int table, const Row& row) override;
  void Describe(int table, const std::string& key, const std::string& value) override;
  /// A text attribute on the file's root group (source file, rocklab version).
  void DescribeFile(const std::string& key, const std::string& value) override;
  void Close() override;
  std::vector<std::string> files() const override;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rocklab::exporter
