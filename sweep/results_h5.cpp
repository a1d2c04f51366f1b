#include "sweep/results_h5.h"

#include <hdf5.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <stdexcept>

namespace rocklab::sweep {
namespace {

// Closes an HDF5 handle when it goes out of scope.
class Handle {
 public:
  Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  ~Handle() {
    if (id_ >= 0) close_(id_);
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  hid_t get() const { return id_; }
  bool ok() const { return id_ >= 0; }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

struct Dataset {
  std::vector<double> real;
  std::vector<std::string> text;
};

// Reads dataset `name` of `group` as numbers (float or integer) or text.
Dataset ReadColumn(const std::string& path, hid_t group, const char* name, bool as_text) {
  const std::string where = path + ": /results/" + name + ": ";
  if (H5Lexists(group, name, H5P_DEFAULT) <= 0) {
    throw std::runtime_error(path + ": no column '" + name + "' in /results (a sweep's results?)");
  }
  Handle d(H5Dopen2(group, name, H5P_DEFAULT), H5Dclose);
  if (!d.ok()) throw std::runtime_error(where + "cannot open the dataset");
  Handle type(H5Dget_type(d.get()), H5Tclose);
  Handle space(H5Dget_space(d.get()), H5Sclose);
  if (H5Sget_simple_extent_ndims(space.get()) != 1) throw std::runtime_error(where + "not a 1-D dataset");
  hsize_t n = 0;
  H5Sget_simple_extent_dims(space.get(), &n, nullptr);
  const H5T_class_t cls = H5Tget_class(type.get());
  Dataset out;
  if (as_text) {
    if (cls != H5T_STRING || H5Tis_variable_str(type.get()) <= 0) {
      throw std::runtime_error(where + "not a variable-length string column");
    }
    std::vector<char*> p(n, nullptr);
    Handle mem(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(mem.get(), H5T_VARIABLE);
    H5Tset_cset(mem.get(), H5T_CSET_UTF8);
    if (n > 0 && H5Dread(d.get(), mem.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, p.data()) < 0) {
      throw std::runtime_error(where + "read failed");
    }
    out.text.reserve(n);
    for (char* q : p) out.text.emplace_back(q ? q : "");
    if (n > 0) H5Dvlen_reclaim(mem.get(), space.get(), H5P_DEFAULT, p.data());
    return out;
  }
  if (cls != H5T_FLOAT && cls != H5T_INTEGER) throw std::runtime_error(where + "not a numeric column");
  out.real.resize(n);
  if (n > 0 && H5Dread(d.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.real.data()) < 0) {
    throw std::runtime_error(where + "read failed");
  }
  return out;
}

herr_t CollectName(hid_t, const char* name, const H5L_info_t*, void* names) {
  static_cast<std::vector<std::string>*>(names)->emplace_back(name);
  return 0;
}

}  // namespace

std::vector<ResultRow> ReadResultsH5(const std::string& path) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);  // errors become exceptions here, not stderr
  Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!file.ok()) throw std::runtime_error(path + ": cannot open as HDF5");
  if (H5Lexists(file.get(), "results", H5P_DEFAULT) <= 0) {
    throw std::runtime_error(path + ": no table /results (written by rocklab sweep --out FILE.h5?)");
  }
  Handle group(H5Gopen2(file.get(), "results", H5P_DEFAULT), H5Gclose);
  if (!group.ok()) throw std::runtime_error(path + ": /results is not a group");
  const Dataset record = ReadColumn(path, group.get(), "record", true);
  const Dataset model = ReadColumn(path, group.get(), "model", true);
  const bool has_block = H5Lexists(group.get(), "block", H5P_DEFAULT) > 0;
  const Dataset block = has_block ? ReadColumn(path, group.get(), "block", true) : Dataset{};
  const char* const numeric[] = {"scale", "pga_g", "alpha", "p", "mu", "peak_theta_over_alpha", "overturned"};
  std::vector<Dataset> numbers;
  for (const char* name : numeric) numbers.push_back(ReadColumn(path, group.get(), name, false));
  const std::size_t n = record.text.size();
  if (model.text.size() != n) throw std::runtime_error(path + ": /results: columns of different lengths");
  for (std::size_t k = 0; k < numbers.size(); ++k) {
    if (numbers[k].real.size() != n) throw std::runtime_error(path + ": /results: columns of different lengths");
  }
  std::vector<ResultRow> rows(n);
  for (std::size_t i = 0; i < n; ++i) {
    const std::string where = path + ": /results row " + std::to_string(i + 1) + ": ";
    ResultRow& r = rows[i];
    r.record = record.text[i];
    r.model = model.text[i];
    if (i < block.text.size() && !block.text[i].empty()) r.block = block.text[i];
    double* out[] = {&r.scale, &r.pga_g, &r.alpha, &r.p, &r.mu, &r.peak_theta_over_alpha};
    for (std::size_t k = 0; k < 6; ++k) {
      *out[k] = numbers[k].real[i];
      if (!std::isfinite(*out[k])) throw std::runtime_error(where + numeric[k] + " is not a finite number");
    }
    const double over = numbers[6].real[i];
    if (over != 0 && over != 1) throw std::runtime_error(where + "overturned is not 0 or 1");
    r.overturned = over == 1;
    if (!(r.pga_g > 0) || !(r.alpha > 0)) throw std::runtime_error(where + "pga_g and alpha must be > 0");
    // The block's name: the values as the CSV writes them (12 significant
    // digits, sweep.cpp), so a block reads the same from either file.
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.12g", r.alpha);
    r.alpha_text = buf;
    std::snprintf(buf, sizeof buf, "%.12g", r.p);
    r.p_text = buf;
    std::snprintf(buf, sizeof buf, "%.12g", r.mu);
    r.mu_text = buf;
  }
  return rows;
}

std::vector<H5ResultsColumn> ReadResultsColumnsH5(const std::string& path) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);  // errors become exceptions here, not stderr
  Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!file.ok()) throw std::runtime_error(path + ": cannot open as HDF5");
  if (H5Lexists(file.get(), "results", H5P_DEFAULT) <= 0) {
    throw std::runtime_error(path + ": no table /results (written by rocklab sweep --out FILE.h5?)");
  }
  Handle group(H5Gopen2(file.get(), "results", H5P_DEFAULT), H5Gclose);
  if (!group.ok()) throw std::runtime_error(path + ": /results is not a group");
  std::vector<std::string> names;
  hsize_t at = 0;
  if (H5Literate(group.get(), H5_INDEX_NAME, H5_ITER_INC, &at, CollectName, &names) < 0) {
    throw std::runtime_error(path + ": cannot list /results");
  }
  std::vector<H5ResultsColumn> out;
  for (const std::string& name : names) {
    H5ResultsColumn c;
    c.name = name;
    c.kind = '?';
    {
      Handle d(H5Dopen2(group.get(), name.c_str(), H5P_DEFAULT), H5Dclose);
      if (!d.ok()) throw std::runtime_error(path + ": /results/" + name + ": not a dataset");
      Handle type(H5Dget_type(d.get()), H5Tclose);
      const H5T_class_t cls = H5Tget_class(type.get());
      if (cls == H5T_FLOAT) c.kind = 'd';
      if (cls == H5T_INTEGER) c.kind = 'i';
      if (cls == H5T_STRING && H5Tis_variable_str(type.get()) > 0) c.kind = 's';
    }
    if (c.kind == 's') {
      c.text = ReadColumn(path, group.get(), name.c_str(), true).text;
    } else if (c.kind == 'd') {
      c.real = ReadColumn(path, group.get(), name.c_str(), false).real;
    } else if (c.kind == 'i') {
      // As int64, not through double: every value as the file holds it.
      const std::string where = path + ": /results/" + name + ": ";
      Handle d(H5Dopen2(group.get(), name.c_str(), H5P_DEFAULT), H5Dclose);
      Handle space(H5Dget_space(d.get()), H5Sclose);
      if (H5Sget_simple_extent_ndims(space.get()) != 1) throw std::runtime_error(where + "not a 1-D dataset");
      hsize_t n = 0;
      H5Sget_simple_extent_dims(space.get(), &n, nullptr);
      c.integer.resize(n);
      if (n > 0 && H5Dread(d.get(), H5T_NATIVE_INT64, H5S_ALL, H5S_ALL, H5P_DEFAULT, c.integer.data()) < 0) {
        throw std::runtime_error(where + "read failed");
      }
    }
    out.push_back(std::move(c));
  }
  return out;
}

}  // namespace rocklab::sweep
