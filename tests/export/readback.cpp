#include "tests/export/readback.h"

#include <gtest/gtest.h>
#include <hdf5.h>
#include <matio.h>

#include <fstream>
#include <sstream>

namespace rocklab::test {
namespace {

std::string ReadAttrText(hid_t obj, const char* name) {
  if (H5Aexists(obj, name) <= 0) return "";
  hid_t a = H5Aopen(obj, name, H5P_DEFAULT);
  hid_t t = H5Aget_type(a);
  std::string out;
  if (H5Tis_variable_str(t) > 0) {
    char* p = nullptr;
    hid_t mt = H5Tcopy(H5T_C_S1);
    H5Tset_size(mt, H5T_VARIABLE);
    H5Tset_cset(mt, H5T_CSET_UTF8);
    if (H5Aread(a, mt, &p) >= 0 && p) out = p;
    H5free_memory(p);
    H5Tclose(mt);
  }
  H5Tclose(t);
  H5Aclose(a);
  return out;
}

// A 1-D attribute of strings (empty when absent).
std::vector<std::string> ReadAttrStrings(hid_t obj, const char* name) {
  std::vector<std::string> out;
  if (H5Aexists(obj, name) <= 0) return out;
  hid_t a = H5Aopen(obj, name, H5P_DEFAULT);
  hid_t as = H5Aget_space(a);
  hsize_t n = 0;
  H5Sget_simple_extent_dims(as, &n, nullptr);
  std::vector<char*> p(n);
  hid_t mt = H5Tcopy(H5T_C_S1);
  H5Tset_size(mt, H5T_VARIABLE);
  H5Tset_cset(mt, H5T_CSET_UTF8);
  if (n && H5Aread(a, mt, p.data()) >= 0) {
    for (char* q : p) out.emplace_back(q ? q : "");
    H5Dvlen_reclaim(mt, as, H5P_DEFAULT, p.data());
  }
  H5Tclose(mt);
  H5Sclose(as);
  H5Aclose(a);
  return out;
}

std::vector<std::int64_t> ReadAttrInts(hid_t obj, const char* name) {
  std::vector<std::int64_t> out;
  if (H5Aexists(obj, name) <= 0) return out;
  hid_t a = H5Aopen(obj, name, H5P_DEFAULT);
  hid_t as = H5Aget_space(a);
  hsize_t n = 0;
  H5Sget_simple_extent_dims(as, &n, nullptr);
  out.resize(n);
  if (n) H5Aread(a, H5T_NATIVE_INT64, out.data());
  H5Sclose(as);
  H5Aclose(a);
  return out;
}

std::string Utf8(const std::vector<std::uint16_t>& u) {
  std::string s;
  for (std::size_t i = 0; i < u.size(); ++i) {
    std::uint32_t cp = u[i];
    if (cp >= 0xD800 && cp < 0xDC00 && i + 1 < u.size()) cp = 0x10000 + ((cp - 0xD800) << 10) + (u[++i] - 0xDC00);
    if (cp < 0x80) {
      s += static_cast<char>(cp);
    } else if (cp < 0x800) {
      s += static_cast<char>(0xC0 | (cp >> 6));
      s += static_cast<char>(0x80 | (cp & 0x3F));
    } else if (cp < 0x10000) {
      s += static_cast<char>(0xE0 | (cp >> 12));
      s += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
      s += static_cast<char>(0x80 | (cp & 0x3F));
    } else {
      s += static_cast<char>(0xF0 | (cp >> 18));
      s += static_cast<char>(0x80 | ((cp >> 12) & 0x3F));
      s += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
      s += static_cast<char>(0x80 | (cp & 0x3F));
    }
  }
  return s;
}

}  // namespace

std::vector<ReadColumn> ReadH5Table(const std::string& path, const std::string& group) {
  std::vector<ReadColumn> out;
  hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) {
    ADD_FAILURE() << path << ": H5Fopen failed";
    return out;
  }
  hid_t g = H5Gopen2(f, group.c_str(), H5P_DEFAULT);
  if (g < 0) {
    ADD_FAILURE() << path << ": no group " << group;
    H5Fclose(f);
    return out;
  }
  H5G_info_t gi{};
  H5Gget_info(g, &gi);
  for (hsize_t k = 0; k < gi.nlinks; ++k) {
    char name[512];
    H5Lget_name_by_idx(g, ".", H5_INDEX_CRT_ORDER, H5_ITER_INC, k, name, sizeof name, H5P_DEFAULT);
    ReadColumn c;
    c.name = name;
    hid_t d = H5Dopen2(g, name, H5P_DEFAULT);
    hid_t t = H5Dget_type(d);
    hid_t s = H5Dget_space(d);
    hsize_t n = 0;
    H5Sget_simple_extent_dims(s, &n, nullptr);
    c.unit = ReadAttrText(d, "units");
    c.description = ReadAttrText(d, "description");
    c.code_values = ReadAttrInts(d, "code_values");
    c.code_names = ReadAttrStrings(d, "code_names");
    c.code_kind = ReadAttrText(d, "code_kind");
    if (H5Tget_class(t) == H5T_FLOAT) {
      c.kind = 'd';
      c.real.resize(n);
      if (n) H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, c.real.data());
    } else if (H5Tget_class(t) == H5T_INTEGER) {
      c.kind = 'i';
      c.integer.resize(n);
      if (n) H5Dread(d, H5T_NATIVE_INT64, H5S_ALL, H5S_ALL, H5P_DEFAULT, c.integer.data());
    } else {
      c.kind = 's';
      std::vector<char*> p(n);
      hid_t mt = H5Tcopy(H5T_C_S1);
      H5Tset_size(mt, H5T_VARIABLE);
      H5Tset_cset(mt, H5T_CSET_UTF8);
      if (n) H5Dread(d, mt, H5S_ALL, H5S_ALL, H5P_DEFAULT, p.data());
      for (char* q : p) c.text.emplace_back(q ? q : "");
      if (n) H5Dvlen_reclaim(mt, s, H5P_DEFAULT, p.data());
      H5Tclose(mt);
    }
    H5Sclose(s);
    H5Tclose(t);
    H5Dclose(d);
    out.push_back(std::move(c));
  }
  // The `columns` attribute lists the same names in the same order.
  hid_t a = H5Aopen(g, "columns", H5P_DEFAULT);
  if (a < 0) {
    ADD_FAILURE() << path << ": " << group << " has no columns attribute";
  } else {
    hid_t as = H5Aget_space(a);
    hsize_t n = 0;
    H5Sget_simple_extent_dims(as, &n, nullptr);
    std::vector<char*> p(n);
    hid_t mt = H5Tcopy(H5T_C_S1);
    H5Tset_size(mt, H5T_VARIABLE);
    H5Tset_cset(mt, H5T_CSET_UTF8);
    if (n) H5Aread(a, mt, p.data());
    EXPECT_EQ(n, out.size()) << group;
    for (std::size_t i = 0; i < n && i < out.size(); ++i) EXPECT_EQ(std::string(p[i]), out[i].name);
    if (n) H5Dvlen_reclaim(mt, as, H5P_DEFAULT, p.data());
    H5Tclose(mt);
    H5Sclose(as);
    H5Aclose(a);
  }
  H5Gclose(g);
  H5Fclose(f);
  return out;
}

std::vector<std::string> H5Groups(const std::string& path) {
  std::vector<std::string> out;
  hid_t f = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (f < 0) return out;
  H5G_info_t gi{};
  H5Gget_info(f, &gi);
  for (hsize_t k = 0; k < gi.nlinks; ++k) {
    char name[512];
    H5Lget_name_by_idx(f, ".", H5_INDEX_NAME, H5_ITER_INC, k, name, sizeof name, H5P_DEFAULT);
    out.emplace_back(name);
  }
  H5Fclose(f);
  return out;
}

std::vector<ReadColumn> ReadMatTable(const std::string& path, const std::string& variable) {
  std::vector<ReadColumn> out;
  mat_t* mat = Mat_Open(path.c_str(), MAT_ACC_RDONLY);
  if (!mat) {
    ADD_FAILURE() << path << ": Mat_Open failed";
    return out;
  }
  EXPECT_EQ(Mat_GetVersion(mat), MAT_FT_MAT5) << path;
  matvar_t* st = Mat_VarRead(mat, variable.c_str());
  if (!st || st->class_type != MAT_C_STRUCT) {
    ADD_FAILURE() << path << ": no struct " << variable;
    if (st) Mat_VarFree(st);
    Mat_Close(mat);
    return out;
  }
  const unsigned nf = Mat_VarGetNumberOfFields(st);
  char* const* names = Mat_VarGetStructFieldnames(st);
  for (unsigned k = 0; k < nf; ++k) {
    matvar_t* f = Mat_VarGetStructFieldByIndex(st, k, 0);
    ReadColumn c;
    c.name = names[k];
    const std::size_t rows = f->rank >= 1 ? f->dims[0] : 0;
    if (f->class_type == MAT_C_DOUBLE) {
      c.kind = 'd';
      EXPECT_EQ(f->dims[1], 1u) << c.name;
      const auto* p = static_cast<const double*>(f->data);
      c.real.assign(p, p + rows);
    } else if (f->class_type == MAT_C_INT64) {
      c.kind = 'i';
      const auto* p = static_cast<const std::int64_t*>(f->data);
      c.integer.assign(p, p + rows);
    } else if (f->class_type == MAT_C_CHAR) {
      c.kind = 's';
      const std::size_t width = f->dims[1];
      EXPECT_EQ(f->data_size, 2) << c.name << ": char data not 16-bit";
      const auto* p = static_cast<const std::uint16_t*>(f->data);
      for (std::size_t r = 0; r < rows; ++r) {
        std::vector<std::uint16_t> u;
        for (std::size_t j = 0; j < width; ++j) u.push_back(p[j * rows + r]);
        while (!u.empty() && u.back() == ' ') u.pop_back();
        c.text.push_back(Utf8(u));
      }
    } else {
      ADD_FAILURE() << variable << "." << c.name << ": unexpected class " << f->class_type;
    }
    out.push_back(std::move(c));
  }
  Mat_VarFree(st);
  Mat_Close(mat);
  return out;
}

std::vector<std::string> MatVariables(const std::string& path) {
  std::vector<std::string> out;
  mat_t* mat = Mat_Open(path.c_str(), MAT_ACC_RDONLY);
  if (!mat) return out;
  while (matvar_t* v = Mat_VarReadNextInfo(mat)) {
    out.emplace_back(v->name);
    Mat_VarFree(v);
  }
  Mat_Close(mat);
  return out;
}

std::vector<ReadColumn> ReadCsvTable(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  std::string text = ss.str();
  // `#` lines before the header (a sweep's definition) are not the table's.
  while (!text.empty() && text[0] == '#') {
    const std::size_t end = text.find('\n');
    text.erase(0, end == std::string::npos ? text.size() : end + 1);
  }
  std::vector<std::vector<std::string>> rows;
  std::vector<std::string> row;
  std::string field;
  bool quoted = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char ch = text[i];
    if (quoted) {
      if (ch == '"' && i + 1 < text.size() && text[i + 1] == '"') {
        field += '"';
        ++i;
      } else if (ch == '"') {
        quoted = false;
      } else {
        field += ch;
      }
    } else if (ch == '"') {
      quoted = true;
    } else if (ch == ',') {
      row.push_back(field);
      field.clear();
    } else if (ch == '\n') {
      row.push_back(field);
      field.clear();
      rows.push_back(row);
      row.clear();
    } else {
      field += ch;
    }
  }
  std::vector<ReadColumn> out;
  if (rows.empty()) return out;
  for (const std::string& name : rows[0]) {
    ReadColumn c;
    c.name = name;
    c.kind = 's';
    out.push_back(c);
  }
  for (std::size_t r = 1; r < rows.size(); ++r) {
    EXPECT_EQ(rows[r].size(), out.size()) << path << " line " << r + 1;
    for (std::size_t k = 0; k < out.size() && k < rows[r].size(); ++k) out[k].text.push_back(rows[r][k]);
  }
  return out;
}

}  // namespace rocklab::test
