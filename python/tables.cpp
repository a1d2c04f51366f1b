#include "python/tables.h"

#include <algorithm>
#include <cstring>

#include <pybind11/stl.h>

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

// Copies a column into a field of a structured array (strided).
template <typename T>
void FillField(py::array& field, const std::vector<T>& values) {
  auto* base = static_cast<char*>(field.mutable_data());
  const py::ssize_t stride = field.strides(0);
  for (std::size_t k = 0; k < values.size(); ++k) {
    std::memcpy(base + static_cast<py::ssize_t>(k) * stride, &values[k], sizeof(T));
  }
}

}  // namespace

py::dict NumpySink::ToNumpy() const {
  py::module_ np = py::module_::import("numpy");
  py::dict out;
  for (const Table& t : tables_) {
    py::list fields;
    py::dict units;
    for (std::size_t i = 0; i < t.columns.size(); ++i) {
      const exporter::Column& c = t.columns[i];
      std::string format = "f8";
      if (c.type == exporter::ColumnType::kInt) format = "i8";
      if (c.type == exporter::ColumnType::kString) {
        std::size_t longest = 1;
        for (const std::string& s : t.text[i]) longest = std::max(longest, s.size());
        format = "U" + std::to_string(longest);
      }
      py::dict field_meta;
      field_meta["unit"] = c.unit;
      fields.append(py::make_tuple(c.name, np.attr("dtype")(format, py::arg("metadata") = field_meta)));
      units[py::str(c.name)] = c.unit;
    }
    py::dict meta;
    for (const auto& [key, value] : t.attributes) meta[py::str(key)] = value;
    meta["units"] = units;
    py::object dtype = np.attr("dtype")(fields, py::arg("metadata") = meta);
    py::array array = np.attr("empty")(t.rows, dtype);
    for (std::size_t i = 0; i < t.columns.size(); ++i) {
      const exporter::Column& c = t.columns[i];
      if (c.type == exporter::ColumnType::kString) {
        array[py::str(c.name)] = py::cast(t.text[i]);
        continue;
      }
      py::array field = array.attr("__getitem__")(c.name);
      if (c.type == exporter::ColumnType::kDouble) FillField(field, t.real[i]);
      if (c.type == exporter::ColumnType::kInt) FillField(field, t.integer[i]);
    }
    out[py::str(t.name)] = array;
  }
  return out;
}

}  // namespace rocklab::python
