// MAT v5 export through libmatio (mat_writer.h): spool per column, write
// each struct at Close from memory-mapped spool files.
#include "export/mat_writer.h"

#include <fcntl.h>
#include <matio.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <optional>
#include <set>
#include <stdexcept>

#include "common/atomic_file.h"

namespace rocklab::exporter {
namespace {

// The largest variable MAT v5 can hold (its sizes are 32-bit), with room for
// the struct's headers, bytes.
constexpr std::uint64_t kMaxVariableBytes = (1ull << 31) - (1ull << 20);

// An unlinked temporary file written through stdio.
class Spool {
 public:
  explicit Spool(const std::string& dir) {
    std::string templ = dir + "/.rocklab-export-XXXXXX";
    int fd = mkstemp(templ.data());
    if (fd < 0) throw std::runtime_error(dir + ": cannot create a spool file: " + std::strerror(errno));
    unlink(templ.c_str());
    f_ = fdopen(fd, "w+b");
    if (!f_) {
      close(fd);
      throw std::runtime_error(dir + ": cannot open a spool file");
    }
  }
  ~Spool() {
    Unmap();
    if (f_) std::fclose(f_);
  }
  Spool(const Spool&) = delete;
  Spool& operator=(const Spool&) = delete;
  void Write(const void* p, std::size_t n) { std::fwrite(p, 1, n, f_); }
  // Flushes and maps the whole file read-only; nullptr when it is empty.
  const void* Map(std::size_t& size, const std::string& path) {
    if (std::fflush(f_) != 0 || std::ferror(f_)) {
      throw std::runtime_error(path + ": spool file write failed (disk full?)");
    }
    size = static_cast<std::size_t>(std::ftell(f_));
    size_ = size;
    if (size == 0) return nullptr;
    map_ = mmap(nullptr, size, PROT_READ, MAP_PRIVATE, fileno(f_), 0);
    if (map_ == MAP_FAILED) {
      map_ = nullptr;
      throw std::runtime_error(path + ": cannot map a spool file: " + std::strerror(errno));
    }
    return map_;
  }
  void Unmap() {
    if (map_) munmap(map_, size_);
    map_ = nullptr;
  }

 private:
  std::FILE* f_{};
  void* map_{};
  std::size_t size_{};
};

// UTF-8 to UTF-16 code units (invalid bytes: U+FFFD), appended to `out`.
void Utf16(const std::string& s, std::vector<std::uint16_t>& out) {
  out.clear();
  std::size_t i = 0;
  while (i < s.size()) {
    const auto b = static_cast<unsigned char>(s[i]);
    std::uint32_t cp = 0xFFFD;
    int n = 0;
    if (b < 0x80) {
      cp = b;
      n = 1;
    } else if ((b >> 5) == 0x6) {
      cp = b & 0x1F;
      n = 2;
    } else if ((b >> 4) == 0xE) {
      cp = b & 0x0F;
      n = 3;
    } else if ((b >> 3) == 0x1E) {
      cp = b & 0x07;
      n = 4;
    }
    bool ok = n > 0 && i + static_cast<std::size_t>(n) <= s.size();
    for (int k = 1; ok && k < n; ++k) {
      const auto c = static_cast<unsigned char>(s[i + static_cast<std::size_t>(k)]);
      ok = (c >> 6) == 0x2;
      cp = (cp << 6) | (c & 0x3F);
    }
    if (!ok) {
      cp = 0xFFFD;
      n = 1;
    }
    i += static_cast<std::size_t>(n);
    if (cp >= 0x10000) {
      cp -= 0x10000;
      out.push_back(static_cast<std::uint16_t>(0xD800 + (cp >> 10)));
      out.push_back(static_cast<std::uint16_t>(0xDC00 + (cp & 0x3FF)));
    } else {
      out.push_back(static_cast<std::uint16_t>(cp));
    }
  }
}

struct MatColumn {
  Column column;
  std::string field;  // MATLAB identifier
  std::unique_ptr<Spool> spool;
  std::size_t longest{};  // text: UTF-16 code units of the longest string
};

struct MatTable {
  std::string variable;
  std::vector<MatColumn> columns;
  std::uint64_t rows{};
};

std::string Unique(const std::string& base, std::set<std::string>& taken) {
  std::string name = base;
  for (int k = 2; !taken.insert(name).second; ++k) {
    std::string suffix = "_" + std::to_string(k);
    name = base.substr(0, 63 - suffix.size()) + suffix;
  }
  return name;
}

}  // namespace

constexpr const char* kLegendVariable = "rocklab_columns";
constexpr const char* kProvenanceVariable = "rocklab_provenance";

struct MatWriter::Impl {
  std::string path;  // the target, as messages name it
  std::string dir;
  std::optional<common::AtomicFile> out;  // matio writes out->path()
  mat_t* mat{};
  std::vector<MatTable> tables;
  std::set<std::string> variables;
  std::vector<std::pair<std::string, std::string>> file_attributes;  // DescribeFile, in order
  std::vector<std::uint16_t> utf16;  // scratch

  void WriteTable(MatTable& t) {
    std::uint64_t bytes = 0;
    for (const MatColumn& c : t.columns) {
      bytes += t.rows * (c.column.type == ColumnType::kString ? 2 * std::max<std::size_t>(c.longest, 1) : 8);
    }
    if (bytes > kMaxVariableBytes) {
      throw std::runtime_error(path + ": table " + t.variable + " has " + std::to_string(bytes) +
                               " bytes, more than a MAT v5 variable holds (2^31): export to .h5");
    }
    std::vector<const char*> names;
    for (const MatColumn& c : t.columns) names.push_back(c.field.c_str());
    names.push_back(nullptr);
    size_t one[2] = {1, 1};
    matvar_t* st = Mat_VarCreateStruct2(t.variable.c_str(), 2, one, names.data());
    if (!st) throw std::runtime_error(path + ": matio cannot create struct " + t.variable);
    std::vector<std::vector<std::uint16_t>> text_data;  // kept until the write
    for (MatColumn& c : t.columns) {
      std::size_t size = 0;
      const void* data = c.spool->Map(size, path);
      size_t dims[2] = {static_cast<size_t>(t.rows), 1};
      matvar_t* field = nullptr;
      if (c.column.type == ColumnType::kDouble) {
        field = Mat_VarCreate(nullptr, MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims, const_cast<void*>(data),
                              MAT_F_DONT_COPY_DATA);
      } else if (c.column.type == ColumnType::kInt) {
        field = Mat_VarCreate(nullptr, MAT_C_INT64, MAT_T_INT64, 2, dims, const_cast<void*>(data),
                              MAT_F_DONT_COPY_DATA);
      } else {
        // N x L, column-major: element (r, k) at k * N + r.
        const std::size_t width = std::max<std::size_t>(c.longest, 1);
        text_data.emplace_back(t.rows * width, static_cast<std::uint16_t>(' '));
        std::vector<std::uint16_t>& chars = text_data.back();
        const auto* p = static_cast<const unsigned char*>(data);
        std::string s;
        for (std::uint64_t r = 0; r < t.rows; ++r) {
          std::uint32_t n = 0;
          std::memcpy(&n, p, 4);
          s.assign(reinterpret_cast<const char*>(p + 4), n);
          p += 4 + n;
          Utf16(s, utf16);
          for (std::size_t k = 0; k < utf16.size(); ++k) chars[k * t.rows + r] = utf16[k];
        }
        dims[1] = width;
        field = Mat_VarCreate(nullptr, MAT_C_CHAR, MAT_T_UINT16, 2, dims, chars.data(),
                              MAT_F_DONT_COPY_DATA);
      }
      if (!field) {
        Mat_VarFree(st);
        throw std::runtime_error(path + ": matio cannot create field " + t.variable + "." + c.field);
      }
      Mat_VarSetStructFieldByName(st, c.field.c_str(), 0, field);
    }
    const int r = Mat_VarWrite(mat, st, MAT_COMPRESSION_NONE);
    Mat_VarFree(st);  // the fields' data is not theirs (MAT_F_DONT_COPY_DATA)
    for (MatColumn& c : t.columns) c.spool.reset();
    if (r != 0) throw std::runtime_error(path + ": matio could not write " + t.variable + " (disk full?)");
  }
};

MatWriter::MatWriter(const std::string& path) : impl_(new Impl) {
  impl_->path = path;
  const std::size_t slash = path.find_last_of('/');
  impl_->dir = slash == std::string::npos ? "." : (slash == 0 ? "/" : path.substr(0, slash));
  impl_->out.emplace(path);
  impl_->mat = Mat_CreateVer(impl_->out->path().c_str(), "rocklab export (MAT v5)", MAT_FT_MAT5);
  if (!impl_->mat) throw std::runtime_error(path + ": cannot create the MAT file");
  impl_->variables.insert(kLegendVariable);  // a table of that name becomes rocklab_columns_2
  impl_->variables.insert(kProvenanceVariable);
}

MatWriter::~MatWriter() {
  // Not closed: matio's handle is let go and the temporary removed (the
  // AtomicFile), so the target keeps what it held.
  if (impl_->mat) Mat_Close(impl_->mat);
}

std::string MatWriter::Identifier(const std::string& name) {
  std::string id;
  for (char c : name) {
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_';
    id += ok ? c : '_';
  }
  if (id.empty() || !((id[0] >= 'A' && id[0] <= 'Z') || (id[0] >= 'a' && id[0] <= 'z'))) id = "x" + id;
  if (id.size() > 63) id.resize(63);
  return id;
}

int MatWriter::AddTable(const std::string& name, const std::vector<Column>& columns) {
  Impl& m = *impl_;
  if (!m.mat) throw std::logic_error(m.path + ": AddTable after Close");
  MatTable t;
  t.variable = Unique(Identifier(name), m.variables);
  std::set<std::string> fields;
  for (const Column& c : columns) {
    MatColumn mc;
    mc.column = c;
    mc.field = Unique(Identifier(c.name), fields);
    mc.spool = std::make_unique<Spool>(m.dir);
    t.columns.push_back(std::move(mc));
  }
  m.tables.push_back(std::move(t));
  return static_cast<int>(m.tables.size()) - 1;
}

void MatWriter::Append(int table, const Row& row) {
  Impl& m = *impl_;
  MatTable& t = m.tables.at(static_cast<std::size_t>(table));
  for (std::size_t i = 0; i < t.columns.size(); ++i) {
    MatColumn& c = t.columns[i];
    switch (c.column.type) {
      case ColumnType::kDouble: c.spool->Write(&row.real[i], 8); break;
      case ColumnType::kInt: c.spool->Write(&row.integer[i], 8); break;
      case ColumnType::kString: {
        const std::string& s = row.text[i];
        const auto n = static_cast<std::uint32_t>(s.size());
        c.spool->Write(&n, 4);
        c.spool->Write(s.data(), s.size());
        Utf16(s, m.utf16);
        c.longest = std::max(c.longest, m.utf16.size());
        break;
      }
    }
  }
  ++t.rows;
}

void MatWriter::Close() {
  Impl& m = *impl_;
  if (!m.mat) return;
  std::string error;
  // The legend: every column's unit, codes and description, named as in
  // the file (variable, field), written last as one more table.
  if (!m.tables.empty()) {
    try {
      std::vector<Row> rows;
      for (const MatTable& t : m.tables) {
        std::vector<Column> columns;
        for (const MatColumn& c : t.columns) {
          columns.push_back(c.column);
          columns.back().name = c.field;
        }
        AppendLegendRows(t.variable, columns, rows);
      }
      MatTable legend;
      legend.variable = kLegendVariable;
      for (const Column& c : LegendColumns()) {
        MatColumn mc;
        mc.column = c;
        mc.field = c.name;
        mc.spool = std::make_unique<Spool>(m.dir);
        legend.columns.push_back(std::move(mc));
      }
      m.tables.push_back(std::move(legend));
      for (const Row& r : rows) Append(static_cast<int>(m.tables.size()) - 1, r);
    } catch (const std::exception& e) {
      error = e.what();
    }
  }
  // The provenance: a struct of one text field per key (DescribeFile).
  if (!m.file_attributes.empty() && error.empty()) {
    try {
      MatTable provenance;
      provenance.variable = kProvenanceVariable;
      std::set<std::string> fields;
      Row row;
      for (const auto& [key, value] : m.file_attributes) {
        MatColumn mc;
        mc.column = {key, ColumnType::kString, ""};
        mc.field = Unique(Identifier(key), fields);
        mc.spool = std::make_unique<Spool>(m.dir);
        provenance.columns.push_back(std::move(mc));
        row.text.push_back(value);
      }
      row.real.resize(row.text.size());
      row.integer.resize(row.text.size());
      m.tables.push_back(std::move(provenance));
      Append(static_cast<int>(m.tables.size()) - 1, row);
    } catch (const std::exception& e) {
      error = e.what();
    }
  }
  for (MatTable& t : m.tables) {
    try {
      if (error.empty()) m.WriteTable(t);
    } catch (const std::exception& e) {
      error = e.what();
    }
  }
  m.tables.clear();
  if (Mat_Close(m.mat) != 0 && error.empty()) error = m.path + ": closing the MAT file failed";
  m.mat = nullptr;
  if (!error.empty()) throw std::runtime_error(error);
  m.out->Commit();
}

void MatWriter::DescribeFile(const std::string& key, const std::string& value) {
  impl_->file_attributes.emplace_back(key, value);
}

std::vector<std::string> MatWriter::files() const { return {impl_->path}; }

}  // namespace rocklab::exporter
