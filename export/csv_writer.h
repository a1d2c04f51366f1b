#pragma once
/// @file
/// CSV export: one file per table, a header row of the column names, one
/// line per row. Reals with 17 significant digits (they read back to the
/// same double), NaN as `NaN`, infinities as `inf`/`-inf`; integers in
/// decimal; text always in double quotes with `"` doubled; names quoted
/// where they hold a comma, a quote or a line break. UTF-8, `\n` line ends.
///
/// Metadata CSV has no place for in a table's file (units, the names of
/// codes, descriptions) goes to one legend file, LegendPath(out).
///
/// Each file is written beside its name (common::AtomicFile) and Close()
/// renames them all once every one is complete; a writer destroyed without
/// Close() leaves the previous files as they were.

#include <cstdio>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "common/atomic_file.h"
#include "export/table.h"

namespace rocklab::exporter {

class CsvWriter final : public TableSink {
 public:
  /// `out` ends in .csv. single_table: the one table goes to `out` itself
  /// (a raw file's export); otherwise table T goes to OUTDIR/STEM_T.csv
  /// (STEM: `out` without .csv; T with every character outside
  /// [A-Za-z0-9_-] replaced by `_`).
  CsvWriter(std::string out, bool single_table);
  /// Without Close(): the temporaries are removed, nothing is renamed.
  ~CsvWriter() override;
  int AddTable(const std::string& name, const std::vector<Column>& columns) override;
  void Append(int table, const Row& row) override;
  void Close() override;
  std::vector<std::string> files() const override;

  /// The file a table named `name` goes to when not single_table.
  static std::string TablePath(const std::string& out, const std::string& name);
  /// The legend file (export/table.h: LegendColumns) Close() writes beside
  /// the tables: STEM.columns.csv (one row per column of every table: its
  /// unit, codes and description).
  static std::string LegendPath(const std::string& out);
  /// The provenance file Close() writes beside the tables when DescribeFile
  /// was called: STEM.provenance.csv, columns key,value.
  static std::string ProvenancePath(const std::string& out);
  void DescribeFile(const std::string& key, const std::string& value) override;

 private:
  struct File {
    common::AtomicFile file;
    std::FILE* f{};  // file's stream
    std::vector<Column> columns;
    std::string name;  // the table's
  };
  std::string out_;
  bool single_table_;
  bool closed_{false};
  std::vector<File> files_;
  std::vector<std::pair<std::string, std::string>> file_attributes_;  // DescribeFile, in order
};

}  // namespace rocklab::exporter
