#pragma once
/// @file
/// A progress bar on stderr for long offline work (`run --max`, `replay
/// --max`, `report`, `export`, `fit`): the share of the input read (bytes of
/// the file), the rate and the time left, redrawn in place at most 10 times a
/// second:
///
///   export   [##########----------]  50%   12.3 MB/s   0:42 left
///
/// Silent when the descriptor is not a terminal (a pipe, a file, CI) or when
/// the command was given --quiet. No allocation after construction: Update
/// reads the clock and, when a redraw is due, formats into a fixed buffer
/// and write(2)s it.

#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <string>
#include <thread>

namespace rocklab::common {

class Progress {
 public:
  /// `label`: a short word, kept by pointer (a string literal). `total`:
  /// the input's size, bytes (<= 0: unknown, the bar shows bytes read
  /// only). Draws on `fd` only when `isatty(fd)` and !quiet.
  Progress(const char* label, std::int64_t total, bool quiet, int fd = 2);
  /// Finish().
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  /// `done` bytes of the input read so far. Cheap when no redraw is due.
  void Update(std::int64_t done);
  /// Clears the bar's line (once); later Updates draw nothing.
  void Finish();
  /// Whether anything is drawn.
  bool active() const { return active_; }

  /// The bar's text (no `\r`) into `out` (at most `size` bytes with the
  /// NUL): label, bar of `width` cells, percent, rate (B/s, kB/s, MB/s,
  /// GB/s), time left (m:ss, or h:mm:ss). `elapsed_s` <= 0 or nothing
  /// done: no rate, "--:--" left. Returns the length written.
  static std::size_t Format(char* out, std::size_t size, const char* label, std::int64_t done,
                            std::int64_t total, double elapsed_s, int width = 20);

 private:
  const char* label_;
  std::int64_t total_;
  int fd_;
  bool active_{false};
  std::chrono::steady_clock::time_point start_, next_draw_;
  char line_[160]{};
};

/// A Progress fed by the read position of an input file that a library
/// reads (LogReader, the DAQ's sources, the report, the fits): a thread wakes
/// every 100 ms, finds the descriptor this process has open on `path`
/// (/proc/self/fd, Linux) and reads its offset (/proc/self/fdinfo). A
/// command only constructs one around its work; no reader changes. The
/// thread exists only while the bar is drawn (a terminal, no --quiet); it
/// allocates nothing per update. A file read twice (a counting pass, then
/// the work) shows twice.
class FileProgress {
 public:
  FileProgress(const char* label, const std::string& path, bool quiet, int fd = 2);
  /// Stops the thread and clears the bar.
  ~FileProgress();
  FileProgress(const FileProgress&) = delete;
  FileProgress& operator=(const FileProgress&) = delete;
  bool active() const { return progress_.active(); }

 private:
  void Watch();
  std::int64_t Position();

  Progress progress_;
  std::string path_;  // as realpath() gives it, what /proc/self/fd links name
  int watched_fd_{-1};
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace rocklab::common
