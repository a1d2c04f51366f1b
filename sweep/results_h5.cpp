#include "sweep/results_h5.h"

#include <hdf5.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <stdexcept>

#include "common/text.h"
#include "sweep/row_writer.h"

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

hid_t OpenFile(const std::string& path) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);  // errors become exceptions here, not stderr
  const hid_t id = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (id < 0) throw std::runtime_error(path + ": cannot open as HDF5");
  return id;
}

std::uintmax_t FileBytes(const std::string& path) {
  std::error_code ec;
  const std::uintmax_t bytes = std::filesystem::file_size(path, ec);
  if (ec) throw std::runtime_error(path + ": cannot tell its size: " + ec.message());
  return bytes;
}

hid_t OpenGroup(const std::string& path, hid_t file) {
  if (H5Lexists(file, "results", H5P_DEFAULT) <= 0) {
    throw std::runtime_error(path + ": no table /results (written by rocklab sweep --out FILE.h5?)");
  }
  const hid_t id = H5Gopen2(file, "results", H5P_DEFAULT);
  if (id < 0) throw std::runtime_error(path + ": /results is not a group");
  return id;
}

// An open results file: the file, its /results group and its size in bytes.
class ResultsFile {
 public:
  explicit ResultsFile(const std::string& path)
      : path_(path), file_(OpenFile(path), H5Fclose), bytes_(FileBytes(path)),
        group_(OpenGroup(path, file_.get()), H5Gclose) {}
  const std::string& path() const { return path_; }
  hid_t file() const { return file_.get(); }
  hid_t group() const { return group_.get(); }
  std::uintmax_t bytes() const { return bytes_; }

 private:
  std::string path_;
  Handle file_;
  std::uintmax_t bytes_;
  Handle group_;
};

// A dataset of /results, opened and checked against the file's size before
// anything is allocated for it (results_h5.h).
struct Column {
  Column(const ResultsFile& f, const std::string& name)
      : where(f.path() + ": /results/" + name + ": "),
        d(H5Dopen2(f.group(), name.c_str(), H5P_DEFAULT), H5Dclose),
        type(d.ok() ? H5Dget_type(d.get()) : -1, H5Tclose),
        space(d.ok() ? H5Dget_space(d.get()) : -1, H5Sclose) {
    if (!d.ok()) throw std::runtime_error(where + "not a dataset");
    if (!type.ok() || !space.ok()) throw std::runtime_error(where + "cannot read its type and shape");
    if (H5Sget_simple_extent_type(space.get()) != H5S_SIMPLE || H5Sget_simple_extent_ndims(space.get()) != 1) {
      throw std::runtime_error(where + "not a 1-D dataset");
    }
    if (H5Sget_simple_extent_dims(space.get(), &rows, nullptr) != 1) throw std::runtime_error(where + "no shape");
    const unsigned long long most = f.bytes() / kMinFileBytesPerRow;
    if (rows > most) {
      throw std::runtime_error(where + "declares " + std::to_string(rows) + " rows, more than a file of " +
                               std::to_string(f.bytes()) + " bytes can hold (at most " + std::to_string(most) +
                               ", " + std::to_string(kMinFileBytesPerRow) + " bytes a row): a damaged file");
    }
    const H5T_class_t cls = H5Tget_class(type.get());
    const std::size_t size = H5Tget_size(type.get());
    if (cls == H5T_FLOAT || cls == H5T_INTEGER) {
      kind = cls == H5T_FLOAT ? 'd' : 'i';
      if (size == 0 || size > 8) throw std::runtime_error(where + "numbers of " + std::to_string(size) + " bytes");
    } else if (cls == H5T_STRING && H5Tis_variable_str(type.get()) > 0) {
      kind = 's';
    }
    Handle dcpl(H5Dget_create_plist(d.get()), H5Pclose);
    if (!dcpl.ok()) throw std::runtime_error(where + "cannot read its storage");
    const H5D_layout_t layout = H5Pget_layout(dcpl.get());
    if (layout != H5D_CONTIGUOUS && layout != H5D_CHUNKED && layout != H5D_COMPACT) {
      throw std::runtime_error(where + "stored outside the file's own layouts (virtual?)");
    }
    if (H5Pget_external_count(dcpl.get()) != 0) throw std::runtime_error(where + "stored in an external file");
    if (layout == H5D_CHUNKED) {
      hsize_t chunk = 0;
      if (H5Pget_chunk(dcpl.get(), 1, &chunk) != 1) throw std::runtime_error(where + "chunks that are not 1-D");
      const unsigned long long element = kind == 's' ? sizeof(hvl_t) : std::max<std::size_t>(size, 1);
      if (chunk == 0 || chunk > kMaxChunkBytes / element) {
        throw std::runtime_error(where + "chunks of " + std::to_string(chunk) + " rows, more than " +
                                 std::to_string(kMaxChunkBytes) + " bytes: a damaged file");
      }
    }
  }

  std::vector<double> Doubles() const {
    std::vector<double> out(rows);
    if (rows > 0 && H5Dread(d.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) < 0) {
      throw std::runtime_error(where + "read failed");
    }
    return out;
  }

  std::vector<std::int64_t> Integers() const {
    std::vector<std::int64_t> out(rows);
    if (rows > 0 && H5Dread(d.get(), H5T_NATIVE_INT64, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()) < 0) {
      throw std::runtime_error(where + "read failed");
    }
    return out;
  }

  // Variable-length strings, read kStringBlock rows at a time: their bytes
  // are summed as they come and may not pass the file's size (each string
  // is an object of the file's global heap), so what they take is bounded
  // by the file's size plus one block. (H5Dvlen_get_buf_size would size
  // them first, but one row at a time: 20 s for 20 000 rows.)
  std::vector<std::string> Texts(std::uintmax_t file_bytes) const {
    if (kind != 's') throw std::runtime_error(where + "not a variable-length string column");
    constexpr hsize_t kStringBlock = 4096;
    std::vector<std::string> out;
    out.reserve(rows);
    Handle mem(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(mem.get(), H5T_VARIABLE);
    H5Tset_cset(mem.get(), H5T_CSET_UTF8);
    std::vector<char*> p(static_cast<std::size_t>(std::min(rows, kStringBlock)), nullptr);
    std::uintmax_t bytes = 0;
    for (hsize_t first = 0; first < rows; first += kStringBlock) {
      hsize_t count = std::min(kStringBlock, rows - first);
      Handle block(H5Scopy(space.get()), H5Sclose);
      Handle memory(H5Screate_simple(1, &count, nullptr), H5Sclose);
      if (!block.ok() || !memory.ok() ||
          H5Sselect_hyperslab(block.get(), H5S_SELECT_SET, &first, nullptr, &count, nullptr) < 0) {
        throw std::runtime_error(where + "cannot select rows " + std::to_string(first + 1));
      }
      std::fill(p.begin(), p.end(), nullptr);
      if (H5Dread(d.get(), mem.get(), memory.get(), block.get(), H5P_DEFAULT, p.data()) < 0) {
        throw std::runtime_error(where + "read failed");
      }
      for (hsize_t k = 0; k < count; ++k) {
        const char* q = p[k] ? p[k] : "";
        bytes += std::strlen(q);
        if (bytes <= file_bytes) out.emplace_back(q);
      }
      H5Dvlen_reclaim(mem.get(), memory.get(), H5P_DEFAULT, p.data());
      if (bytes > file_bytes) {
        throw std::runtime_error(where + "strings of more than " + std::to_string(file_bytes) +
                                 " bytes in a file of that size: a damaged file");
      }
    }
    return out;
  }

  std::string where;
  Handle d, type, space;
  hsize_t rows{};
  char kind{'?'};
};

bool HasLink(const ResultsFile& f, const char* name) { return H5Lexists(f.group(), name, H5P_DEFAULT) > 0; }

Column Open(const ResultsFile& f, const char* name) {
  if (!HasLink(f, name)) {
    throw std::runtime_error(f.path() + ": no column '" + name + "' in /results (a sweep's results?)");
  }
  return Column(f, name);
}

// A string attribute of the root, read by name; false when there is none.
bool RootText(const ResultsFile& f, const std::string& name, std::string& value) {
  if (H5Aexists(f.file(), name.c_str()) <= 0) return false;
  const std::string where = f.path() + ": attribute " + name + ": ";
  Handle a(H5Aopen(f.file(), name.c_str(), H5P_DEFAULT), H5Aclose);
  if (!a.ok()) throw std::runtime_error(where + "cannot open it");
  Handle type(H5Aget_type(a.get()), H5Tclose);
  Handle space(H5Aget_space(a.get()), H5Sclose);
  if (!type.ok() || !space.ok() || H5Tget_class(type.get()) != H5T_STRING ||
      H5Sget_simple_extent_type(space.get()) != H5S_SCALAR) {
    throw std::runtime_error(where + "not a text");
  }
  if (H5Tis_variable_str(type.get()) > 0) {
    Handle mem(H5Tcopy(H5T_C_S1), H5Tclose);
    H5Tset_size(mem.get(), H5T_VARIABLE);
    H5Tset_cset(mem.get(), H5T_CSET_UTF8);
    char* p = nullptr;
    if (H5Aread(a.get(), mem.get(), &p) < 0) throw std::runtime_error(where + "read failed");
    value = p ? p : "";
    H5free_memory(p);
  } else {
    const std::size_t size = H5Tget_size(type.get());
    if (size == 0 || size > f.bytes()) throw std::runtime_error(where + "a text longer than its file");
    std::string buf(size, '\0');
    if (H5Aread(a.get(), type.get(), buf.data()) < 0) throw std::runtime_error(where + "read failed");
    value = buf.substr(0, buf.find('\0'));
  }
  return true;
}

// The definition: kH5DefinitionKeys names the attributes, read one by one.
Definition ReadDefinition(const ResultsFile& f) {
  Definition d;
  std::string keys;
  if (!RootText(f, kH5DefinitionKeys, keys)) return d;
  std::size_t from = 0;
  while (from < keys.size()) {
    std::size_t end = keys.find(' ', from);
    if (end == std::string::npos) end = keys.size();
    const std::string key = keys.substr(from, end - from);
    from = end + 1;
    if (key.empty()) continue;
    DefinitionField field{key, ""};
    if (!RootText(f, kH5DefinitionPrefix + key, field.value)) {
      throw std::runtime_error(f.path() + ": attribute " + kH5DefinitionKeys + " names " + common::Quote(key) +
                               ", which the file lacks (a damaged file)");
    }
    d.push_back(std::move(field));
  }
  return d;
}

std::vector<ResultRow> ReadRows(const std::string& path) {
  const ResultsFile f(path);
  const std::vector<std::string> record = Open(f, "record").Texts(f.bytes());
  const std::vector<std::string> model = Open(f, "model").Texts(f.bytes());
  const std::vector<std::string> block = HasLink(f, "block") ? Open(f, "block").Texts(f.bytes())
                                                             : std::vector<std::string>{};
  const std::vector<std::string> first_body = HasLink(f, "first_overturned_body")
                                                  ? Open(f, "first_overturned_body").Texts(f.bytes())
                                                  : std::vector<std::string>{};
  const char* const numeric[] = {"scale", "pga_g", "alpha", "p", "mu", "peak_theta_over_alpha", "overturned"};
  std::vector<std::vector<double>> numbers;
  for (const char* name : numeric) {
    Column c = Open(f, name);
    if (c.kind != 'd' && c.kind != 'i') throw std::runtime_error(c.where + "not a numeric column");
    numbers.push_back(c.Doubles());
  }
  const std::size_t n = record.size();
  if (model.size() != n) throw std::runtime_error(path + ": /results: columns of different lengths");
  for (const std::vector<double>& column : numbers) {
    if (column.size() != n) throw std::runtime_error(path + ": /results: columns of different lengths");
  }
  std::vector<ResultRow> rows(n);
  for (std::size_t i = 0; i < n; ++i) {
    ResultRow& r = rows[i];
    r.record = record[i];
    r.model = model[i];
    if (i < block.size() && !block[i].empty()) r.block = block[i];
    double* out[] = {&r.scale, &r.pga_g, &r.alpha, &r.p, &r.mu, &r.peak_theta_over_alpha};
    for (std::size_t k = 0; k < 6; ++k) *out[k] = numbers[k][i];
    const std::string problem = RowProblem({r.scale, r.pga_g, r.alpha, r.p, r.mu, r.peak_theta_over_alpha, numbers[6][i]});
    if (!problem.empty()) throw std::runtime_error(path + ": /results row " + std::to_string(i + 1) + ": " + problem);
    r.overturned = numbers[6][i] == 1;
    if (i < first_body.size() && r.overturned) r.first_overturned_body = first_body[i];
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

H5ResultsTable ReadTable(const std::string& path, const std::vector<std::string>& names) {
  const ResultsFile f(path);
  H5ResultsTable out;
  H5G_info_t info{};
  if (H5Gget_info(f.group(), &info) < 0) throw std::runtime_error(path + ": cannot count the links of /results");
  out.links = static_cast<std::size_t>(info.nlinks);
  for (const std::string& name : names) {
    H5ResultsColumn c;
    c.name = name;
    if (HasLink(f, name.c_str())) {
      const Column column(f, name);
      c.kind = column.kind;
      if (c.kind == 's') c.text = column.Texts(f.bytes());
      if (c.kind == 'd') c.real = column.Doubles();
      if (c.kind == 'i') c.integer = column.Integers();  // as int64, not through double
    }
    out.columns.push_back(std::move(c));
  }
  out.definition = ReadDefinition(f);
  return out;
}

// --- libhdf5 in a child process. Debian's libhdf5 (1.10) crashes on some
// damaged files in its own metadata reads, whatever the caller asks:
// H5Literate freed an uninitialised pointer, and H5Lexists of /results on
// a shard with one byte set to 0xff overruns a buffer (H5F__accum_read,
// SweepMerge.ByteDamagedHdf5ShardsAreErrorsNotCrashes). No order of calls
// avoids that, so a file is read in a forked child that sends what it read
// back through a pipe; a child that dies is a clear error naming the file.

// What the child sends: 'R' and the result, or 'E' and its message.
class Encoder {
 public:
  void U64(std::uint64_t v) { Bytes(&v, sizeof v); }
  void Text(const std::string& t) {
    U64(t.size());
    Bytes(t.data(), t.size());
  }
  template <typename T>
  void Array(const std::vector<T>& v) {
    U64(v.size());
    Bytes(v.data(), v.size() * sizeof(T));
  }
  void Bytes(const void* p, std::size_t n) { out.append(static_cast<const char*>(p), n); }
  std::string out;
};

class Decoder {
 public:
  Decoder(const std::string& in, const std::string& path) : in_(in), path_(path) {}
  std::uint64_t U64() {
    std::uint64_t v = 0;
    Bytes(&v, sizeof v);
    return v;
  }
  std::string Text() {
    const std::uint64_t n = Count(1);
    std::string t(in_.data() + at_, n);
    at_ += n;
    return t;
  }
  template <typename T>
  std::vector<T> Array() {
    std::vector<T> v(Count(sizeof(T)));
    Bytes(v.data(), v.size() * sizeof(T));
    return v;
  }

 private:
  // A count of items of `size` bytes that the rest of the message can hold.
  std::uint64_t Count(std::size_t size) {
    const std::uint64_t n = U64();
    if (n > (in_.size() - at_) / size) Short();
    return n;
  }
  void Bytes(void* p, std::size_t n) {
    if (n > in_.size() - at_) Short();
    if (n > 0) std::memcpy(p, in_.data() + at_, n);
    at_ += n;
  }
  [[noreturn]] void Short() const { throw std::runtime_error(path_ + ": the HDF5 reader's answer was cut short"); }
  const std::string& in_;
  const std::string& path_;
  std::size_t at_{0};
};

void Encode(Encoder& e, const std::vector<ResultRow>& rows) {
  e.U64(rows.size());
  for (const ResultRow& r : rows) {
    for (const std::string* t :
         {&r.record, &r.model, &r.alpha_text, &r.p_text, &r.mu_text, &r.block, &r.first_overturned_body}) {
      e.Text(*t);
    }
    for (double v : {r.scale, r.pga_g, r.alpha, r.p, r.mu, r.peak_theta_over_alpha}) e.Bytes(&v, sizeof v);
    e.U64(r.overturned ? 1 : 0);
  }
}

void Decode(Decoder& d, std::vector<ResultRow>& rows) {
  const std::uint64_t n = d.U64();
  for (std::uint64_t i = 0; i < n; ++i) {
    ResultRow r;
    for (std::string* t :
         {&r.record, &r.model, &r.alpha_text, &r.p_text, &r.mu_text, &r.block, &r.first_overturned_body}) {
      *t = d.Text();
    }
    for (double* v : {&r.scale, &r.pga_g, &r.alpha, &r.p, &r.mu, &r.peak_theta_over_alpha}) {
      const std::uint64_t bits = d.U64();
      std::memcpy(v, &bits, sizeof *v);
    }
    r.overturned = d.U64() != 0;
    rows.push_back(std::move(r));
  }
}

void Encode(Encoder& e, const H5ResultsTable& t) {
  e.U64(t.links);
  e.U64(t.columns.size());
  for (const H5ResultsColumn& c : t.columns) {
    e.Text(c.name);
    e.U64(static_cast<unsigned char>(c.kind));
    e.Array(c.real);
    e.Array(c.integer);
    e.U64(c.text.size());
    for (const std::string& x : c.text) e.Text(x);
  }
  e.U64(t.definition.size());
  for (const DefinitionField& f : t.definition) {
    e.Text(f.key);
    e.Text(f.value);
  }
}

void Decode(Decoder& d, H5ResultsTable& t) {
  t.links = d.U64();
  const std::uint64_t columns = d.U64();
  for (std::uint64_t k = 0; k < columns; ++k) {
    H5ResultsColumn c;
    c.name = d.Text();
    c.kind = static_cast<char>(d.U64());
    c.real = d.Array<double>();
    c.integer = d.Array<std::int64_t>();
    const std::uint64_t texts = d.U64();
    for (std::uint64_t i = 0; i < texts; ++i) c.text.push_back(d.Text());
    t.columns.push_back(std::move(c));
  }
  const std::uint64_t fields = d.U64();
  for (std::uint64_t k = 0; k < fields; ++k) {
    DefinitionField f;
    f.key = d.Text();
    f.value = d.Text();
    t.definition.push_back(std::move(f));
  }
}

void WriteAll(int fd, const std::string& bytes) {
  std::size_t at = 0;
  while (at < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + at, bytes.size() - at);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return;
    at += static_cast<std::size_t>(n);
  }
}

// The child's address space is capped at what it has mapped plus 512 MiB
// plus 64 times the file's size (above the readers' own bound, results_h5.h),
// so an allocation libhdf5 makes from a damaged size fails in the child
// instead of taking the machine's memory. Not under ASan, whose shadow
// memory needs terabytes of address space.
#if defined(__SANITIZE_ADDRESS__)
#define ROCKLAB_UNDER_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define ROCKLAB_UNDER_ASAN 1
#endif
#endif
void CapAddressSpace(const std::string& path) {
#ifdef ROCKLAB_UNDER_ASAN
  (void)path;
#else
  long pages = 0;
  if (std::FILE* f = std::fopen("/proc/self/statm", "r")) {
    if (std::fscanf(f, "%ld", &pages) != 1) pages = 0;
    std::fclose(f);
  }
  std::error_code ec;
  const std::uintmax_t bytes = std::filesystem::file_size(path, ec);
  if (pages <= 0 || ec || bytes > (std::uintmax_t{1} << 40)) return;  // no cap rather than a wrong one
  const rlim_t cap = static_cast<rlim_t>(pages) * static_cast<rlim_t>(::sysconf(_SC_PAGESIZE)) +
                     (rlim_t{512} << 20) + static_cast<rlim_t>(bytes) * 64;
  rlimit limit{};
  if (::getrlimit(RLIMIT_AS, &limit) == 0 && (limit.rlim_cur == RLIM_INFINITY || limit.rlim_cur > cap)) {
    limit.rlim_cur = cap;
    ::setrlimit(RLIMIT_AS, &limit);
  }
#endif
}

// Runs read(path) in a forked child and returns its result, or throws its
// std::runtime_error's message; a child that dies throws naming the file.
template <typename Result, typename Read>
Result Isolated(const std::string& path, Read read) {
  int fds[2];
  if (::pipe(fds) != 0) throw std::runtime_error(path + ": cannot make a pipe: " + std::strerror(errno));
  std::fflush(nullptr);  // nothing buffered is written twice
  const pid_t child = ::fork();
  if (child < 0) {
    ::close(fds[0]);
    ::close(fds[1]);
    throw std::runtime_error(path + ": cannot fork the HDF5 reader: " + std::strerror(errno));
  }
  if (child == 0) {
    ::close(fds[0]);
    CapAddressSpace(path);
    Encoder e;
    try {
      const Result result = read(path);
      e.Bytes("R", 1);
      Encode(e, result);
    } catch (const std::exception& ex) {
      e.out.clear();
      e.Bytes("E", 1);
      e.Text(ex.what());
    }
    WriteAll(fds[1], e.out);
    ::_exit(0);  // no atexit handlers: the parent's files and HDF5 state stay the parent's
  }
  ::close(fds[1]);
  std::string answer;
  char buf[65536];
  for (;;) {
    const ssize_t n = ::read(fds[0], buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    answer.append(buf, static_cast<std::size_t>(n));
  }
  ::close(fds[0]);
  int status = 0;
  while (::waitpid(child, &status, 0) < 0 && errno == EINTR) {
  }
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0 || answer.empty()) {
    const std::string how = WIFSIGNALED(status) ? "signal " + std::to_string(WTERMSIG(status))
                                                : "exit " + std::to_string(WEXITSTATUS(status));
    throw std::runtime_error(path + ": a damaged HDF5 file: libhdf5 failed reading it (its reader ended by " + how +
                             ")");
  }
  const std::string body = answer.substr(1);
  Decoder d(body, path);
  if (answer[0] == 'E') throw std::runtime_error(d.Text());
  Result result;
  Decode(d, result);
  return result;
}

}  // namespace

std::vector<ResultRow> ReadResultsH5(const std::string& path) {
  return Isolated<std::vector<ResultRow>>(path, [](const std::string& p) { return ReadRows(p); });
}

H5ResultsTable ReadResultsTableH5(const std::string& path, const std::vector<std::string>& names) {
  return Isolated<H5ResultsTable>(path, [&names](const std::string& p) { return ReadTable(p, names); });
}

}  // namespace rocklab::sweep

