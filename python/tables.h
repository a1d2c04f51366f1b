#pragma once
// The export library's tables (export/table.h) as numpy structured arrays:
// a TableSink that keeps every column in C++ while the library reads (the
// GIL released), then builds one array per table, one field per column,
// each field's unit in its dtype's metadata.

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "export/table.h"
#include "python/bindings.h"

namespace rocklab::python {

class NumpySink final : public exporter::TableSink {
 public:
  /// `progress`: told the rows read so far (not owned; may be null).
  explicit NumpySink(ProgressHook* progress = nullptr) : progress_(progress) {}
  int AddTable(const std::string& name, const std::vector<exporter::Column>& columns) override;
  void Append(int table, const exporter::Row& row) override;
  void Describe(int table, const std::string& key, const std::string& value) override;
  void Close() override {}
  std::vector<std::string> files() const override { return {}; }

  /// ({table name: structured array}, {table name: info}); needs the GIL.
  /// A field with a unit has the title "name [unit]"; a table's info holds
  /// its attributes (channel, lcm_type, source) and `units` ({field: unit}).
  py::tuple ToNumpy() const;
  std::int64_t rows() const { return rows_; }

 private:
  struct Table {
    std::string name;
    std::vector<exporter::Column> columns;
    std::vector<std::vector<double>> real;         // per column (kDouble), else empty
    std::vector<std::vector<std::int64_t>> integer;  // per column (kInt), else empty
    std::vector<std::vector<std::string>> text;     // per column (kString), else empty
    std::vector<std::pair<std::string, std::string>> attributes;
    std::size_t rows{};
  };
  std::vector<Table> tables_;
  std::int64_t rows_{};  // all tables
  ProgressHook* progress_;  // not owned; may be null
};

}  // namespace rocklab::python
