#pragma once
// Reads an exported table back with the libraries the researchers' tools
// use underneath (the HDF5 C library, libmatio) and a plain CSV parser, for
// the export tests to compare every value.

#include <cstdint>
#include <string>
#include <vector>

namespace rocklab::test {

struct ReadColumn {
  std::string name;
  char kind{};  ///< 'd' double, 'i' integer, 's' text
  std::vector<double> real;
  std::vector<std::int64_t> integer;
  std::vector<std::string> text;  ///< CSV: every field as written (unquoted)
  std::string unit;               ///< HDF5 only: the `units` attribute
  std::string description;        ///< HDF5 only: the `description` attribute
  std::vector<std::int64_t> code_values;  ///< HDF5 only: `code_values`
  std::vector<std::string> code_names;    ///< HDF5 only: `code_names`
  std::string code_kind;                  ///< HDF5 only: `code_kind`
  std::size_t size() const { return kind == 'd' ? real.size() : kind == 'i' ? integer.size() : text.size(); }
};

/// The datasets of group `group` in creation order (the `columns` attribute's
/// order is checked against it). Fails the test (ADD_FAILURE) on an HDF5 error.
std::vector<ReadColumn> ReadH5Table(const std::string& path, const std::string& group);
/// The fields of the 1x1 struct variable `variable`; char matrices as text
/// (trailing blanks removed, UTF-16 to UTF-8).
std::vector<ReadColumn> ReadMatTable(const std::string& path, const std::string& variable);
/// Header names and fields as text (quotes removed, "" as ").
std::vector<ReadColumn> ReadCsvTable(const std::string& path);
/// The names of the variables of a MAT file / the groups of an HDF5 file.
std::vector<std::string> MatVariables(const std::string& path);
std::vector<std::string> H5Groups(const std::string& path);

}  // namespace rocklab::test
