#pragma once
/// @file
/// MATLAB export (libmatio): a MAT-file version 5 (MATLAB's `-v7` without
/// compression, the format both MATLAB's `load` and scipy.io.loadmat read;
/// scipy cannot read v7.3). Each table is one 1x1 struct variable; each
/// column one field, an N x 1 column: double columns `double`, integer
/// columns `int64`, text columns an N x L `char` matrix (UTF-16 code units,
/// rows padded with spaces to the longest string, L >= 1).
///
/// Names: a table or column name becomes a MATLAB identifier (characters
/// outside [A-Za-z0-9_] replaced by `_`, `x` put before a leading digit or
/// `_`, at most 63 characters, `_2`, `_3`... added where that makes two
/// names equal). MatWriter::Identifier says what a name becomes.
///
/// Metadata: a struct variable `rocklab_columns` (written at Close) is the
/// legend of every table (export/table.h: LegendColumns): fields table,
/// column (the MATLAB identifiers), unit, codes, description, one row per
/// column of every table.
///
/// Memory: MAT v5 writes a variable in one piece, so rows are spooled while
/// they arrive (one unlinked temporary file per column beside the output)
/// and each struct is written at Close from the spool files mapped into
/// memory (file-backed pages the kernel can drop, not heap); text columns
/// are built in memory at Close (2 bytes x rows x longest string). A
/// variable over 2^31 bytes does not fit MAT v5: Close throws and says to
/// export to .h5.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "export/table.h"

namespace rocklab::exporter {

class MatWriter final : public TableSink {
 public:
  /// Writes beside `path` (common::AtomicFile); Close() renames the
  /// complete file to `path`. Destroyed without Close(), the temporary is
  /// removed and `path` keeps what it held. @throws std::runtime_error
  /// naming the file.
  explicit MatWriter(const std::string& path);
  ~MatWriter() override;
  MatWriter(const MatWriter&) = delete;
  MatWriter& operator=(const MatWriter&) = delete;

  int AddTable(const std::string& name, const std::vector<Column>& columns) override;
  void Append(int table, const Row& row) override;
  /// Kept for Close(), which writes them as the struct `rocklab_provenance`.
  void DescribeFile(const std::string& key, const std::string& value) override;
  void Close() override;
  std::vector<std::string> files() const override;

  /// `name` as a MATLAB identifier (without the de-duplicating suffix).
  static std::string Identifier(const std::string& name);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rocklab::exporter
