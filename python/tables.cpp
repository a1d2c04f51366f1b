#include "python/tables.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <string_view>

#include <pybind11/stl.h>

#include "common/text.h"

namespace rocklab::python {

int NumpySink::AddTable(const std::string& name, const std::vector<exporter::Column>& columns) {
  Table t;
  t.name = name;
  t.columns = columns;
  t.real.resize(columns.size());
  t.integer.resize(columns.size());
  t.text.resize(columns.size());
  tables_.push_back(std::move(t));
  return static_cast<int>(tables_.size()) - 1;
}

void NumpySink::Append(int table, const exporter::Row& row) {
  Table& t = tables_[static_cast<std::size_t>(table)];
  for (std::size_t i = 0; i < t.columns.size(); ++i) {
    switch (t.columns[i].type) {
      case exporter::ColumnType::kDouble: t.real[i].push_back(row.real[i]); break;
      case exporter::ColumnType::kInt: t.integer[i].push_back(row.integer[i]); break;
      case exporter::ColumnType::kString: t.text[i].push_back(row.text[i]); break;
    }
  }
  ++t.rows;
  ++rows_;
  if (progress_) progress_->Update(static_cast<double>(rows_));
}

void NumpySink::Describe(int table, const std::string& key, const std::string& value) {
  tables_[static_cast<std::size_t>(table)].attributes.emplace_back(key, value);
}

namespace {

// A field of a structured array to fill without the GIL: its first
// element's address and the array's stride, bytes.
struct FieldSpan {
  char* base;
  py::ssize_t stride;
};

// Copies a column into a field (strided).
template <typename T>
void FillField(const FieldSpan& field, const std::vector<T>& values) {
  for (std::size_t k = 0; k < values.size(); ++k) {
    std::memcpy(field.base + static_cast<py::ssize_t>(k) * field.stride, &values[k], sizeof(T));
  }
}

// Writes `text` as numpy's fixed-width UCS-4 ('U<width>') at `out`: UTF-8
// decoded, a byte that is not well-formed UTF-8 as U+FFFD, zero padded.
// width >= text.size() (one code point at most per byte).
void PutUcs4(char* out, const std::string& text, std::size_t width) {
  std::size_t n = 0;
  const auto put = [&](std::uint32_t cp) { std::memcpy(out + 4 * n++, &cp, 4); };
  for (std::size_t i = 0; i < text.size();) {
    const auto c = static_cast<unsigned char>(text[i]);
    if (c < 0x80) {
      put(c);
      ++i;
      continue;
    }
    const std::size_t more = c >= 0xF0 ? 3 : (c >= 0xE0 ? 2 : 1);
    const std::string_view seq = std::string_view(text).substr(i, more + 1);
    if (seq.size() == more + 1 && common::Utf8ValidPrefix(seq) == seq.size()) {
      std::uint32_t cp = c & (more == 1 ? 0x1F : (more == 2 ? 0x0F : 0x07));
      for (std::size_t k = 1; k <= more; ++k) cp = (cp << 6) | (static_cast<unsigned char>(seq[k]) & 0x3F);
      put(cp);
      i += more + 1;
    } else {
      put(0xFFFD);
      ++i;
    }
  }
  std::memset(out + 4 * n, 0, 4 * (width - n));
}

}  // namespace

py::tuple NumpySink::ToNumpy() const {
  py::module_ np = py::module_::import("numpy");
  py::dict out;
  py::dict info;
  // With the GIL: the dtypes and the (uninitialised) arrays, and where each
  // field lies in them; then without it, the copy, which for a long log is
  // most of the time (a million rows: ~1 s with the GIL held before).
  struct Fill {
    const Table* table;
    std::size_t column;
    FieldSpan span;
    std::size_t width;  // 'U' fields: code points
  };
  std::vector<Fill> fills;
  std::vector<py::array> views;  // keep the fields' views alive while filling
  for (const Table& t : tables_) {
    py::list fields;
    py::dict units;
    std::vector<std::size_t> widths(t.columns.size(), 0);
    for (std::size_t i = 0; i < t.columns.size(); ++i) {
      const exporter::Column& c = t.columns[i];
      std::string format = "f8";
      if (c.type == exporter::ColumnType::kInt) format = "i8";
      if (c.type == exporter::ColumnType::kString) {
        std::size_t longest = 1;
        for (const std::string& s : t.text[i]) longest = std::max(longest, s.size());
        widths[i] = longest;
        format = "U" + std::to_string(longest);
      }
      // The unit rides in the field's title, "name [unit]" (np.save,
      // np.load and pickle keep titles; numpy cannot reload dtype metadata).
      if (c.unit.empty()) {
        fields.append(py::make_tuple(c.name, format));
      } else {
        fields.append(py::make_tuple(py::make_tuple(c.name + " [" + c.unit + "]", c.name), format));
      }
      units[py::str(c.name)] = c.unit;
    }
    py::dict meta;
    for (const auto& [key, value] : t.attributes) meta[py::str(key)] = value;
    meta["units"] = units;
    info[py::str(t.name)] = meta;
    py::object dtype = np.attr("dtype")(fields);
    py::array array = np.attr("empty")(t.rows, dtype);
    for (std::size_t i = 0; i < t.columns.size() && t.rows > 0; ++i) {
      py::array field = array.attr("__getitem__")(t.columns[i].name);
      fills.push_back({&t, i, {static_cast<char*>(field.mutable_data()), field.strides(0)}, widths[i]});
      views.push_back(std::move(field));
    }
    out[py::str(t.name)] = array;
  }
  {
    py::gil_scoped_release release;
    for (const Fill& f : fills) {
      const Table& t = *f.table;
      switch (t.columns[f.column].type) {
        case exporter::ColumnType::kDouble: FillField(f.span, t.real[f.column]); break;
        case exporter::ColumnType::kInt: FillField(f.span, t.integer[f.column]); break;
        case exporter::ColumnType::kString:
          for (std::size_t k = 0; k < t.rows; ++k) {
            PutUcs4(f.span.base + static_cast<py::ssize_t>(k) * f.span.stride, t.text[f.column][k], f.width);
          }
          break;
      }
    }
  }
  return py::make_tuple(out, info);
}

}  // namespace rocklab::python
