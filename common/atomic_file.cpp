// Write beside, rename when complete (atomic_file.h).
#include "common/atomic_file.h"

#include <dirent.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <vector>

namespace rocklab::common {
namespace {

std::string Folder(const std::string& path) {
  const std::size_t slash = path.find_last_of('/');
  if (slash == std::string::npos) return ".";
  return slash == 0 ? "/" : path.substr(0, slash);
}

std::runtime_error Failure(const std::string& target, const char* what, int error) {
  return std::runtime_error("cannot write '" + target + "': " + what + ": " + std::strerror(error));
}

// A name no other writer uses: pid, a process-wide counter and the clock,
// six base-36 digits (O_EXCL settles the rare collision).
std::string Suffix() {
  static std::atomic<std::uint64_t> counter{0};
  std::uint64_t x = static_cast<std::uint64_t>(::getpid()) * 0x9E3779B97F4A7C15ULL;
  x ^= static_cast<std::uint64_t>(std::chrono::steady_clock::now().time_since_epoch().count());
  x ^= (counter.fetch_add(1) + 1) * 0xBF58476D1CE4E5B9ULL;
  x ^= x >> 31;
  static const char kDigits[] = "0123456789abcdefghijklmnopqrstuvwxyz";
  std::string s(6, '0');
  for (char& c : s) {
    c = kDigits[x % 36];
    x /= 36;
  }
  return s;
}

// Removes `TARGET.tmp-PID-*` files of `target` whose process is gone (a
// killed writer's): only AtomicFile makes such names. A PID that is alive,
// or that kill() may not probe, keeps its file; a reused PID keeps it too.
void RemoveLeftovers(const std::string& target) {
  const std::size_t slash = target.find_last_of('/');
  const std::string prefix = (slash == std::string::npos ? target : target.substr(slash + 1)) + ".tmp-";
  DIR* dir = ::opendir(Folder(target).c_str());
  if (dir == nullptr) return;
  std::vector<std::string> stale;
  while (const dirent* e = ::readdir(dir)) {
    const std::string name = e->d_name;
    if (name.compare(0, prefix.size(), prefix) != 0) continue;
    const char* digits = name.c_str() + prefix.size();
    char* end = nullptr;
    errno = 0;
    const long pid = std::strtol(digits, &end, 10);
    if (end == digits || *end != '-' || errno != 0 || pid <= 0 || pid == ::getpid()) continue;
    if (::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH) stale.push_back(name);
  }
  ::closedir(dir);
  const std::string folder = slash == std::string::npos ? "" : target.substr(0, slash + 1);
  for (const std::string& name : stale) ::unlink((folder + name).c_str());
}

void SyncFolder(const std::string& target) {
  // Makes the rename itself durable; a folder that cannot be opened for it
  // (no read permission) still has the rename, only later on disk.
  const int dir = ::open(Folder(target).c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir < 0) return;
  ::fsync(dir);
  ::close(dir);
}

}  // namespace

AtomicFile::AtomicFile(std::string target, std::string_view temp_suffix) : target_(std::move(target)) {
  if (target_.empty() || target_.back() == '/') {
    throw std::runtime_error("cannot write '" + target_ + "': not a file name");
  }
  RemoveLeftovers(target_);
  for (int attempt = 0; attempt < 100; ++attempt) {
    temp_ = target_ + ".tmp-" + std::to_string(::getpid()) + "-" + Suffix() + std::string(temp_suffix);
    fd_ = ::open(temp_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd_ >= 0) return;
    if (errno != EEXIST) break;
  }
  const int error = errno;
  temp_.clear();
  throw Failure(target_, "cannot create a file in its folder", error);
}

AtomicFile::AtomicFile(AtomicFile&& other) noexcept
    : target_(std::move(other.target_)),
      temp_(std::move(other.temp_)),
      fd_(other.fd_),
      stream_(other.stream_),
      finished_(other.finished_),
      committed_(other.committed_) {
  other.temp_.clear();
  other.fd_ = -1;
  other.stream_ = nullptr;
  other.committed_ = true;  // nothing left for the moved-from object to remove
}

AtomicFile::~AtomicFile() {
  if (!committed_) Discard();
}

void AtomicFile::Discard() noexcept {
  if (stream_) {
    std::fclose(stream_);  // closes fd_ too
    stream_ = nullptr;
    fd_ = -1;
  }
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  if (!temp_.empty()) ::unlink(temp_.c_str());
  temp_.clear();
}

std::FILE* AtomicFile::stream() {
  if (stream_) return stream_;
  if (fd_ < 0 || finished_) throw std::logic_error("AtomicFile '" + target_ + "': stream() after Finish()");
  stream_ = ::fdopen(fd_, "w");
  if (!stream_) throw Failure(target_, "fdopen", errno);
  static constexpr std::size_t kBuffer = 1 << 16;
  std::setvbuf(stream_, nullptr, _IOFBF, kBuffer);
  return stream_;
}

void AtomicFile::Finish() {
  if (finished_) return;
  if (temp_.empty()) throw std::logic_error("AtomicFile '" + target_ + "': Finish() after Commit()");
  if (stream_) {
    const bool bad = std::ferror(stream_) != 0;
    const bool flushed = std::fflush(stream_) == 0;
    const int error = errno;
    if (bad || !flushed) throw Failure(target_, "write failed (disk full?)", bad ? EIO : error);
  }
  // fd_ is the temporary's inode whoever wrote it (a library that opened
  // path() itself writes the same inode): fsync covers every writer.
  if (::fsync(fd_) != 0) throw Failure(target_, "fsync", errno);
  if (stream_) {
    const bool closed = std::fclose(stream_) == 0;
    stream_ = nullptr;
    fd_ = -1;
    if (!closed) throw Failure(target_, "close", errno);
  } else {
    ::close(fd_);
    fd_ = -1;
  }
  finished_ = true;
}

void AtomicFile::Commit() {
  if (committed_) return;
  Finish();
  if (std::rename(temp_.c_str(), target_.c_str()) != 0) throw Failure(target_, "rename", errno);
  temp_.clear();
  committed_ = true;
  SyncFolder(target_);
}

void CommitAll(const std::vector<AtomicFile*>& files) {
  for (AtomicFile* f : files) f->Finish();
  for (AtomicFile* f : files) f->Commit();
}

void WriteFileAtomically(const std::string& path, std::string_view text) {
  AtomicFile file(path);
  if (!text.empty() && std::fwrite(text.data(), 1, text.size(), file.stream()) != text.size()) {
    throw Failure(path, "write failed (disk full?)", errno);
  }
  file.Commit();
}

void CommitRename(const std::string& temp, const std::string& target) {
  const int fd = ::open(temp.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw Failure(target, ("cannot open " + temp).c_str(), errno);
  const bool synced = ::fsync(fd) == 0;
  const int error = errno;
  ::close(fd);
  if (!synced) throw Failure(target, "fsync", error);
  if (std::rename(temp.c_str(), target.c_str()) != 0) throw Failure(target, "rename", errno);
  SyncFolder(target);
}

}  // namespace rocklab::common
