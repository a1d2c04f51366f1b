// HDF5 tables (h5_writer.h). Every HDF5 call's result is checked; a failure
// throws naming the file and the call. HDF5's own error printing is turned
// off while a writer exists (it would print a stack for every failure).
#include "export/h5_writer.h"

#include <hdf5.h>

#include <optional>
#include <stdexcept>

#include "common/atomic_file.h"

namespace rocklab::exporter {
namespace {

// Owns one hid_t and closes it with its close function.
class Handle {
 public:
  Handle() = default;
  Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  ~Handle() { Reset(); }
  Handle(Handle&& o) noexcept : id_(o.id_), close_(o.close_) { o.id_ = -1; }
  Handle& operator=(Handle&& o) noexcept {
    if (this != &o) {
      Reset();
      id_ = o.id_;
      close_ = o.close_;
      o.id_ = -1;
    }
    return *this;
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  hid_t get() const { return id_; }
  herr_t Reset() {
    herr_t r = 0;
    if (id_ >= 0 && close_) r = close_(id_);
    id_ = -1;
    return r;
  }

 private:
  hid_t id_{-1};
  herr_t (*close_)(hid_t){};
};

struct ColumnBuffer {
  Column column;
  bool link{false};  // a second name of an earlier dataset (Column::same_as): nothing to write
  Handle dataset;
  std::vector<double> real;
  std::vector<std::int64_t> integer;
  std::vector<std::string> text;
  std::vector<const char*> text_ptrs;
};

struct Table {
  Handle group;
  std::vector<ColumnBuffer> columns;
  std::int64_t buffered{};  // rows gathered, not yet written
  std::int64_t written{};   // rows in the file
};

}  // namespace

void H5WriterOptions::Validate() const {
  if (chunk_rows <= 0) throw std::invalid_argument("chunk_rows must be > 0");
  if (deflate_level < 0 || deflate_level > 9) throw std::invalid_argument("deflate_level must be 0..9");
}

struct H5Writer::Impl {
  std::string path;  // the target, as messages name it
  std::optional<common::AtomicFile> out;  // HDF5 writes out->path()
  H5WriterOptions options;
  Handle file;
  Handle utf8;  // variable-length UTF-8 string type
  std::vector<Table> tables;
  H5E_auto2_t old_func{};
  void* old_data{};

  hid_t Check(hid_t id, const char* call) const {
    if (id < 0) throw std::runtime_error(path + ": HDF5 " + call + " failed");
    return id;
  }
  void Check(herr_t r, const char* call, int) const {
    if (r < 0) throw std::runtime_error(path + ": HDF5 " + call + " failed");
  }

  void TextAttribute(hid_t object, const std::string& key, const std::string& value) {
    Handle space(Check(H5Screate(H5S_SCALAR), "H5Screate"), H5Sclose);
    if (H5Aexists(object, key.c_str()) > 0) Check(H5Adelete(object, key.c_str()), "H5Adelete", 0);
    Handle attr(Check(H5Acreate2(object, key.c_str(), utf8.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT),
                      "H5Acreate2"),
                H5Aclose);
    const char* p = value.c_str();
    Check(H5Awrite(attr.get(), utf8.get(), &p), "H5Awrite", 0);
  }

  // The named values of an integer column: `code_values` (int64) and
  // `code_names` (strings), index for index, and `code_kind` "enum" or
  // "bitmask".
  void CodeAttributes(hid_t object, const Column& c) {
    const hsize_t n = c.codes.size();
    Handle aspace(Check(H5Screate_simple(1, &n, nullptr), "H5Screate_simple"), H5Sclose);
    std::vector<std::int64_t> values;
    std::vector<const char*> names;
    for (const Code& code : c.codes) {
      values.push_back(code.value);
      names.push_back(code.name.c_str());
    }
    Handle v(Check(H5Acreate2(object, "code_values", H5T_STD_I64LE, aspace.get(), H5P_DEFAULT, H5P_DEFAULT),
                   "H5Acreate2"),
             H5Aclose);
    Check(H5Awrite(v.get(), H5T_NATIVE_INT64, values.data()), "H5Awrite", 0);
    Handle t(Check(H5Acreate2(object, "code_names", utf8.get(), aspace.get(), H5P_DEFAULT, H5P_DEFAULT),
                   "H5Acreate2"),
             H5Aclose);
    Check(H5Awrite(t.get(), utf8.get(), names.data()), "H5Awrite", 0);
    TextAttribute(object, "code_kind", c.bitmask ? "bitmask" : "enum");
  }

  void Flush(Table& t) {
    if (t.buffered == 0) return;
    const hsize_t start = static_cast<hsize_t>(t.written);
    const hsize_t count = static_cast<hsize_t>(t.buffered);
    const hsize_t size = start + count;
    for (ColumnBuffer& c : t.columns) {
      if (c.link) continue;
      hid_t d = c.dataset.get();
      Check(H5Dset_extent(d, &size), "H5Dset_extent", 0);
      Handle fspace(Check(H5Dget_space(d), "H5Dget_space"), H5Sclose);
      Check(H5Sselect_hyperslab(fspace.get(), H5S_SELECT_SET, &start, nullptr, &count, nullptr),
            "H5Sselect_hyperslab", 0);
      Handle mspace(Check(H5Screate_simple(1, &count, nullptr), "H5Screate_simple"), H5Sclose);
      switch (c.column.type) {
        case ColumnType::kDouble:
          Check(H5Dwrite(d, H5T_NATIVE_DOUBLE, mspace.get(), fspace.get(), H5P_DEFAULT, c.real.data()),
                "H5Dwrite", 0);
          break;
        case ColumnType::kInt:
          Check(H5Dwrite(d, H5T_NATIVE_INT64, mspace.get(), fspace.get(), H5P_DEFAULT, c.integer.data()),
                "H5Dwrite", 0);
          break;
        case ColumnType::kString:
          for (std::size_t i = 0; i < count; ++i) c.text_ptrs[i] = c.text[i].c_str();
          Check(H5Dwrite(d, utf8.get(), mspace.get(), fspace.get(), H5P_DEFAULT, c.text_ptrs.data()),
                "H5Dwrite", 0);
          break;
      }
    }
    t.written += t.buffered;
    t.buffered = 0;
  }
};

H5Writer::H5Writer(const std::string& path, H5WriterOptions options) : impl_(new Impl) {
  options.Validate();
  impl_->path = path;
  impl_->options = options;
  H5Eget_auto2(H5E_DEFAULT, &impl_->old_func, &impl_->old_data);
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  try {
    impl_->out.emplace(path);
  } catch (...) {
    H5Eset_auto2(H5E_DEFAULT, impl_->old_func, impl_->old_data);
    throw;
  }
  hid_t f = H5Fcreate(impl_->out->path().c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  if (f < 0) {
    H5Eset_auto2(H5E_DEFAULT, impl_->old_func, impl_->old_data);
    throw std::runtime_error(path + ": cannot create the HDF5 file");
  }
  impl_->file = Handle(f, H5Fclose);
  hid_t t = impl_->Check(H5Tcopy(H5T_C_S1), "H5Tcopy");
  impl_->utf8 = Handle(t, H5Tclose);
  impl_->Check(H5Tset_size(t, H5T_VARIABLE), "H5Tset_size", 0);
  impl_->Check(H5Tset_cset(t, H5T_CSET_UTF8), "H5Tset_cset", 0);
}

H5Writer::~H5Writer() {
  // Not closed: HDF5's handles are let go unflushed and the temporary is
  // removed (the AtomicFile), so the target keeps what it held.
  for (Table& t : impl_->tables) {
    for (ColumnBuffer& c : t.columns) c.dataset.Reset();
    t.group.Reset();
  }
  impl_->utf8.Reset();
  impl_->file.Reset();
  impl_->out.reset();
  H5Eset_auto2(H5E_DEFAULT, impl_->old_func, impl_->old_data);
}

int H5Writer::AddTable(const std::string& name, const std::vector<Column>& columns) {
  Impl& m = *impl_;
  if (m.file.get() < 0) throw std::logic_error(m.path + ": AddTable after Close");
  std::string group_name = name;
  for (char& c : group_name) {
    if (c == '/') c = '_';
  }
  if (group_name.empty() || group_name == "." ) group_name = "_";
  Handle lcpl(m.Check(H5Pcreate(H5P_LINK_CREATE), "H5Pcreate"), H5Pclose);
  m.Check(H5Pset_char_encoding(lcpl.get(), H5T_CSET_UTF8), "H5Pset_char_encoding", 0);
  Handle gcpl(m.Check(H5Pcreate(H5P_GROUP_CREATE), "H5Pcreate"), H5Pclose);
  m.Check(H5Pset_link_creation_order(gcpl.get(), H5P_CRT_ORDER_TRACKED | H5P_CRT_ORDER_INDEXED),
          "H5Pset_link_creation_order", 0);
  Table t;
  hid_t g = H5Gcreate2(m.file.get(), group_name.c_str(), lcpl.get(), gcpl.get(), H5P_DEFAULT);
  if (g < 0) throw std::runtime_error(m.path + ": cannot create group " + group_name + " (a second table of that name?)");
  t.group = Handle(g, H5Gclose);

  const hsize_t chunk = static_cast<hsize_t>(m.options.chunk_rows);
  const hsize_t zero = 0, unlimited = H5S_UNLIMITED;
  Handle dcpl(m.Check(H5Pcreate(H5P_DATASET_CREATE), "H5Pcreate"), H5Pclose);
  m.Check(H5Pset_chunk(dcpl.get(), 1, &chunk), "H5Pset_chunk", 0);
  if (m.options.deflate_level > 0) {
    m.Check(H5Pset_shuffle(dcpl.get()), "H5Pset_shuffle", 0);
    m.Check(H5Pset_deflate(dcpl.get(), static_cast<unsigned>(m.options.deflate_level)), "H5Pset_deflate", 0);
  }
  // Whole chunks are written at once: HDF5's chunk cache would only hold them.
  Handle dapl(m.Check(H5Pcreate(H5P_DATASET_ACCESS), "H5Pcreate"), H5Pclose);
  m.Check(H5Pset_chunk_cache(dapl.get(), 0, 0, 1.0), "H5Pset_chunk_cache", 0);
  Handle space(m.Check(H5Screate_simple(1, &zero, &unlimited), "H5Screate_simple"), H5Sclose);

  for (const Column& c : columns) {
    ColumnBuffer b;
    b.column = c;
    if (!c.same_as.empty()) {
      bool earlier = false;
      for (const ColumnBuffer& e : t.columns) earlier = earlier || (!e.link && e.column.name == c.same_as);
      if (!earlier) throw std::logic_error(m.path + ": column " + c.name + " is same_as " + c.same_as + ", not an earlier column");
      if (H5Lcreate_hard(g, c.same_as.c_str(), g, c.name.c_str(), lcpl.get(), H5P_DEFAULT) < 0) {
        throw std::runtime_error(m.path + ": cannot link " + group_name + "/" + c.name + " to " + c.same_as);
      }
      b.link = true;
      t.columns.push_back(std::move(b));
      continue;
    }
    hid_t type = c.type == ColumnType::kDouble ? H5T_IEEE_F64LE
                 : c.type == ColumnType::kInt  ? H5T_STD_I64LE
                                               : m.utf8.get();
    hid_t d = H5Dcreate2(g, c.name.c_str(), type, space.get(), lcpl.get(), dcpl.get(), dapl.get());
    if (d < 0) throw std::runtime_error(m.path + ": cannot create dataset " + group_name + "/" + c.name);
    b.dataset = Handle(d, H5Dclose);
    if (!c.unit.empty()) m.TextAttribute(d, "units", c.unit);
    if (!c.description.empty()) m.TextAttribute(d, "description", c.description);
    if (!c.codes.empty()) m.CodeAttributes(d, c);
    switch (c.type) {
      case ColumnType::kDouble: b.real.resize(chunk); break;
      case ColumnType::kInt: b.integer.resize(chunk); break;
      case ColumnType::kString:
        b.text.resize(chunk);
        b.text_ptrs.resize(chunk);
        break;
    }
    t.columns.push_back(std::move(b));
  }
  // The column order as an attribute too: a reader that lists datasets by
  // name still finds it.
  {
    const hsize_t n = columns.size();
    Handle aspace(m.Check(H5Screate_simple(1, &n, nullptr), "H5Screate_simple"), H5Sclose);
    Handle attr(m.Check(H5Acreate2(g, "columns", m.utf8.get(), aspace.get(), H5P_DEFAULT, H5P_DEFAULT),
                        "H5Acreate2"),
                H5Aclose);
    std::vector<const char*> ptrs;
    for (const Column& c : columns) ptrs.push_back(c.name.c_str());
    if (n > 0) m.Check(H5Awrite(attr.get(), m.utf8.get(), ptrs.data()), "H5Awrite", 0);
  }
  m.tables.push_back(std::move(t));
  return static_cast<int>(m.tables.size()) - 1;
}

void H5Writer::Append(int table, const Row& row) {
  Impl& m = *impl_;
  Table& t = m.tables.at(static_cast<std::size_t>(table));
  const std::size_t k = static_cast<std::size_t>(t.buffered);
  for (std::size_t i = 0; i < t.columns.size(); ++i) {
    ColumnBuffer& c = t.columns[i];
    if (c.link) continue;
    switch (c.column.type) {
      case ColumnType::kDouble: c.real[k] = row.real[i]; break;
      case ColumnType::kInt: c.integer[k] = row.integer[i]; break;
      case ColumnType::kString: c.text[k] = row.text[i]; break;
    }
  }
  if (++t.buffered == m.options.chunk_rows) m.Flush(t);
}

void H5Writer::Describe(int table, const std::string& key, const std::string& value) {
  impl_->TextAttribute(impl_->tables.at(static_cast<std::size_t>(table)).group.get(), key, value);
}

void H5Writer::DescribeFile(const std::string& key, const std::string& value) {
  impl_->TextAttribute(impl_->file.get(), key, value);
}

void H5Writer::Close() {
  Impl& m = *impl_;
  if (m.file.get() < 0) return;
  std::string error;
  for (Table& t : m.tables) {
    try {
      m.Flush(t);
    } catch (const std::exception& e) {
      if (error.empty()) error = e.what();
    }
    for (ColumnBuffer& c : t.columns) c.dataset.Reset();
    t.group.Reset();
  }
  m.utf8.Reset();
  if (H5Fflush(m.file.get(), H5F_SCOPE_GLOBAL) < 0 && error.empty()) error = m.path + ": HDF5 flush failed";
  if (m.file.Reset() < 0 && error.empty()) error = m.path + ": HDF5 close failed";
  if (!error.empty()) throw std::runtime_error(error);
  m.out->Commit();
}

std::vector<std::string> H5Writer::files() const { return {impl_->path}; }

}  // namespace rocklab::exporter
