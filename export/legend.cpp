// The legend table of export/table.h: the metadata of every column for the
// formats that have no attributes per column (CSV, MAT).
#include <string>
#include <vector>

#include "export/table.h"

namespace rocklab::exporter {

std::vector<Column> LegendColumns() {
  return {{"table", ColumnType::kString, ""},
          {"column", ColumnType::kString, ""},
          {"unit", ColumnType::kString, ""},
          {"codes", ColumnType::kString, ""},
          {"description", ColumnType::kString, ""}};
}

std::string CodesText(const Column& c) {
  std::string out;
  for (const Code& code : c.codes) {
    if (!out.empty()) out += ';';
    out += std::to_string(code.value) + (c.bitmask ? "|=" : "=") + code.name;
  }
  return out;
}

void AppendLegendRows(const std::string& table, const std::vector<Column>& columns, std::vector<Row>& rows) {
  for (const Column& c : columns) {
    Row r;
    r.Resize(5);
    r.text[0] = table;
    r.text[1] = c.name;
    r.text[2] = c.unit;
    r.text[3] = CodesText(c);
    r.text[4] = c.description;
    rows.push_back(std::move(r));
  }
}

}  // namespace rocklab::exporter
