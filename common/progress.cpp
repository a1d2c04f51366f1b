#include "common/progress.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <climits>
#include <cstdlib>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <mutex>

namespace rocklab::common {
namespace {

constexpr auto kRedraw = std::chrono::milliseconds(100);  // at most 10 redraws a second

// The bar on screen (at most one: the last drawn) and the lock every draw
// and every PrintAbove takes, so that a log line and a redraw never mix.
std::mutex g_draw_mutex;
Progress* g_shown = nullptr;

void WriteAll(int fd, const char* p, std::size_t n) {
  while (n > 0) {
    const ssize_t w = ::write(fd, p, n);
    if (w <= 0) return;  // a progress bar never stops the work
    p += w;
    n -= static_cast<std::size_t>(w);
  }
}

// "12.3 MB/s" into out.
int FormatRate(char* out, std::size_t size, double bytes_per_s) {
  const char* units[] = {"B/s", "kB/s", "MB/s", "GB/s"};
  int u = 0;
  while (bytes_per_s >= 1000.0 && u < 3) {
    bytes_per_s /= 1000.0;
    ++u;
  }
  return std::snprintf(out, size, "%.1f %s", bytes_per_s, units[u]);
}

}  // namespace

Progress::Progress(const char* label, std::int64_t total, bool quiet, int fd, const char* unit)
    : label_(label), total_(total), fd_(fd), unit_(unit) {
  active_ = !quiet && ::isatty(fd) == 1;
  start_ = std::chrono::steady_clock::now();
  next_draw_ = start_;
}

Progress::~Progress() { Finish(); }

std::size_t Progress::Format(char* out, std::size_t size, const char* label, std::int64_t done,
                             std::int64_t total, double elapsed_s, int width, const char* unit,
                             std::int64_t base) {
  if (size == 0) return 0;
  width = std::clamp(width, 1, 100);
  const bool known = total > 0;
  const double share = known ? std::clamp(static_cast<double>(done) / static_cast<double>(total), 0.0, 1.0) : 0.0;
  char bar[104];
  const int filled = static_cast<int>(share * width + 1e-9);
  for (int i = 0; i < width; ++i) bar[i] = i < filled ? '#' : '-';
  bar[width] = '\0';
  char rate[32] = "";
  char left[32] = "--:-- left";
  if (elapsed_s > 0 && done > base) {
    const double bps = static_cast<double>(done - base) / elapsed_s;
    if (unit != nullptr) {
      std::snprintf(rate, sizeof rate, "%.1f %s/s", bps, unit);
    } else {
      FormatRate(rate, sizeof rate, bps);
    }
    if (known) {
      const auto s = static_cast<long long>(static_cast<double>(std::max<std::int64_t>(total - done, 0)) / bps + 0.5);
      if (s >= 3600) {
        std::snprintf(left, sizeof left, "%lld:%02lld:%02lld left", s / 3600, s / 60 % 60, s % 60);
      } else {
        std::snprintf(left, sizeof left, "%lld:%02lld left", s / 60, s % 60);
      }
    }
  }
  int n;
  if (unit != nullptr && known) {
    n = std::snprintf(out, size, "%-8s [%s] %3d%%  %lld/%lld %s  %s  %s", label, bar, static_cast<int>(share * 100.0),
                      static_cast<long long>(done), static_cast<long long>(total), unit, rate, left);
  } else if (unit != nullptr) {
    n = std::snprintf(out, size, "%-8s %lld %s  %s", label, static_cast<long long>(done), unit, rate);
  } else if (known) {
    n = std::snprintf(out, size, "%-8s [%s] %3d%%  %10s  %s", label, bar,
                      static_cast<int>(share * 100.0), rate, left);
  } else {
    n = std::snprintf(out, size, "%-8s %.1f MB read  %10s", label, static_cast<double>(done) / 1e6, rate);
  }
  if (n < 0) {
    out[0] = '\0';
    return 0;
  }
  return std::min(static_cast<std::size_t>(n), size - 1);
}

void Progress::Update(std::int64_t done) {
  if (!active_) return;
  const auto now = std::chrono::steady_clock::now();
  if (now < next_draw_) return;
  next_draw_ = now + kRedraw;
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  const std::lock_guard<std::mutex> lock(g_draw_mutex);
  line_[0] = '\r';
  std::size_t n = 1 + Format(line_ + 1, sizeof line_ - 5, label_, done, total_, elapsed, 20, unit_, base_);
  std::memcpy(line_ + n, "\033[K", 3);  // erase what a longer line left
  line_size_ = n + 3;
  g_shown = this;
  DrawLocked();
}

void Progress::DrawLocked() { WriteAll(fd_, line_, line_size_); }

void Progress::Finish() {
  if (!active_) return;
  const std::lock_guard<std::mutex> lock(g_draw_mutex);
  active_ = false;
  if (g_shown == this) g_shown = nullptr;
  WriteAll(fd_, "\r\033[K", 4);
}

void Progress::PrintAbove(int fd, const std::function<void()>& print) {
  const std::lock_guard<std::mutex> lock(g_draw_mutex);
  Progress* const bar = g_shown != nullptr && g_shown->fd_ == fd ? g_shown : nullptr;
  if (bar != nullptr) WriteAll(fd, "\r\033[K", 4);
  print();
  if (bar != nullptr) bar->DrawLocked();
}

namespace {
// The size of the regular file `path`, bytes; -1 when it is not one.
std::int64_t RegularFileSize(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return -1;
  return static_cast<std::int64_t>(st.st_size);
}
}  // namespace

FileProgress::FileProgress(const char* label, const std::string& path, bool quiet, int fd)
    : progress_(label, RegularFileSize(path), quiet, fd) {
  char resolved[PATH_MAX];
  if (!progress_.active()) return;
  if (RegularFileSize(path) < 0 || !::realpath(path.c_str(), resolved)) {
    progress_.Finish();  // not a regular file: no share to show
    return;
  }
  path_ = resolved;
  thread_ = std::thread([this] { Watch(); });
}

FileProgress::~FileProgress() {
  stop_.store(true);
  if (thread_.joinable()) thread_.join();
  progress_.Finish();
}

std::int64_t FileProgress::Position() {
  char link[32], target[PATH_MAX];
  auto points_at_file = [&](int fd) {
    std::snprintf(link, sizeof link, "/proc/self/fd/%d", fd);
    const ssize_t n = ::readlink(link, target, sizeof target - 1);
    if (n <= 0) return false;
    target[n] = '\0';
    return path_ == target;
  };
  if (watched_fd_ < 0 || !points_at_file(watched_fd_)) {
    watched_fd_ = -1;
    for (int fd = 3; fd < 1024 && watched_fd_ < 0; ++fd) {
      if (points_at_file(fd)) watched_fd_ = fd;
    }
    if (watched_fd_ < 0) return -1;
  }
  char info_path[48], info[512];
  std::snprintf(info_path, sizeof info_path, "/proc/self/fdinfo/%d", watched_fd_);
  const int f = ::open(info_path, O_RDONLY | O_CLOEXEC);
  if (f < 0) return -1;
  const ssize_t n = ::read(f, info, sizeof info - 1);
  ::close(f);
  if (n <= 0) return -1;
  info[n] = '\0';
  const char* pos = std::strstr(info, "pos:");
  return pos ? std::strtoll(pos + 4, nullptr, 10) : -1;
}

void FileProgress::Watch() {
  while (!stop_.load()) {
    const std::int64_t pos = Position();
    if (pos >= 0) progress_.Update(pos);
    std::this_thread::sleep_for(kRedraw);
  }
}

}  // namespace rocklab::common
