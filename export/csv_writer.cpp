#include "export/csv_writer.h"

#include "common/provenance.h"

#include <cinttypes>
#include <cmath>
#include <cstring>
#include <stdexcept>

namespace rocklab::exporter {
namespace {

// `out` without its .csv: the stem of the tables' and the sidecars' names.
std::string CsvStem(const std::string& out) {
  const bool csv = out.size() >= 4 && out.compare(out.size() - 4, 4, ".csv") == 0;
  return csv ? out.substr(0, out.size() - 4) : out;
}

void WriteQuoted(std::FILE* f, const std::string& s) {
  std::fputc('"', f);
  for (char c : s) {
    if (c == '"') std::fputc('"', f);
    std::fputc(c, f);
  }
  std::fputc('"', f);
}

void WriteName(std::FILE* f, const std::string& s) {
  if (s.find_first_of(",\"\r\n") != std::string::npos) {
    WriteQuoted(f, s);
  } else {
    std::fputs(s.c_str(), f);
  }
}

void WriteReal(std::FILE* f, double x) {
  if (std::isnan(x)) {
    std::fputs("NaN", f);
  } else if (std::isinf(x)) {
    std::fputs(x > 0 ? "inf" : "-inf", f);
  } else {
    std::fprintf(f, "%.17g", x);
  }
}

}  // namespace

CsvWriter::CsvWriter(std::string out, bool single_table)
    : out_(std::move(out)), single_table_(single_table) {}

CsvWriter::~CsvWriter() = default;  // each AtomicFile removes its temporary

std::string CsvWriter::TablePath(const std::string& out, const std::string& name) {
  std::string safe = name;
  for (char& c : safe) {
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                    c == '_' || c == '-';
    if (!ok) c = '_';
  }
  return CsvStem(out) + "_" + safe + ".csv";
}

int CsvWriter::AddTable(const std::string& name, const std::vector<Column>& columns) {
  if (single_table_ && !files_.empty()) {
    throw std::logic_error("CsvWriter: a single-table export got a second table " + name);
  }
  const std::string path = single_table_ ? out_ : TablePath(out_, name);
  for (const File& other : files_) {
    if (other.file.target() == path) {
      throw std::runtime_error(path + ": two tables map to this file name (" + name + ")");
    }
  }
  File file{common::AtomicFile(path), nullptr, columns, name};
  file.f = file.file.stream();
  for (std::size_t i = 0; i < columns.size(); ++i) {
    if (i) std::fputc(',', file.f);
    WriteName(file.f, columns[i].name);
  }
  std::fputc('\n', file.f);
  files_.push_back(std::move(file));
  return static_cast<int>(files_.size()) - 1;
}

void CsvWriter::Append(int table, const Row& row) {
  File& file = files_.at(static_cast<std::size_t>(table));
  std::FILE* f = file.f;
  for (std::size_t i = 0; i < file.columns.size(); ++i) {
    if (i) std::fputc(',', f);
    switch (file.columns[i].type) {
      case ColumnType::kDouble: WriteReal(f, row.real[i]); break;
      case ColumnType::kInt: std::fprintf(f, "%" PRId64, row.integer[i]); break;
      case ColumnType::kString: WriteQuoted(f, row.text[i]); break;
    }
  }
  if (std::fputc('\n', f) == EOF) {
    throw std::runtime_error(file.file.target() + ": write failed: " + std::strerror(errno));
  }
}

std::string CsvWriter::LegendPath(const std::string& out) {
  return CsvStem(out) + ".columns.csv";  // a '.' no TablePath gives: it cannot be a table's file
}

std::string CsvWriter::ProvenancePath(const std::string& out) { return common::ProvenanceSidecarPath(out); }

void CsvWriter::DescribeFile(const std::string& key, const std::string& value) {
  file_attributes_.emplace_back(key, value);
}

void CsvWriter::Close() {
  if (closed_) return;
  if (!files_.empty()) {
    std::vector<Row> legend_rows;
    for (const File& file : files_) AppendLegendRows(file.name, file.columns, legend_rows);
    std::vector<Row> provenance_rows;
    for (const auto& [key, value] : file_attributes_) provenance_rows.push_back({{0, 0}, {0, 0}, {key, value}});
    const bool single = single_table_;
    const std::string out = out_;
    std::vector<File> tables = std::move(files_);
    // Each sidecar through AddTable as a single table at its own path.
    single_table_ = true;
    std::vector<File> sidecars;
    auto add_sidecar = [&](const std::string& path, const std::string& name, const std::vector<Column>& columns,
                           const std::vector<Row>& rows) {
      files_.clear();
      out_ = path;
      const int t = AddTable(name, columns);
      for (const Row& r : rows) Append(t, r);
      sidecars.push_back(std::move(files_.back()));
    };
    add_sidecar(LegendPath(out), "rocklab_columns", LegendColumns(), legend_rows);
    if (!provenance_rows.empty()) {
      add_sidecar(ProvenancePath(out), "rocklab_provenance",
                  {{"key", ColumnType::kString, ""}, {"value", ColumnType::kString, ""}}, provenance_rows);
    }
    files_ = std::move(tables);
    for (File& f : sidecars) files_.push_back(std::move(f));
    out_ = out;
    single_table_ = single;
  }
  closed_ = true;
  std::vector<common::AtomicFile*> all;
  for (File& file : files_) {
    file.f = nullptr;  // Finish closes it
    all.push_back(&file.file);
  }
  common::CommitAll(all);
}

std::vector<std::string> CsvWriter::files() const {
  std::vector<std::string> out;
  for (const File& f : files_) out.push_back(f.file.target());
  return out;
}

}  // namespace rocklab::exporter
