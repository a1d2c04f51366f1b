#pragma once
/// @file
/// The one progress display of the commands (`run --max`, `replay --max`,
/// `report`, `export`, `fit`, `sweep`): one line on stderr with the share
/// done, the rate and the time left, redrawn in place at most 10 times a
/// second. Bytes of an input file, or counted items (`unit`: sweep rows,
/// posterior steps, model runs):
///
///   export   [##########----------]  50%   12.3 MB/s   0:42 left
///   sweep    [####----------------]  20%  120/600 rows  3.2 rows/s  2:30 left
///
/// Log lines go above the bar, never through it: PrintAbove clears the
/// line, prints, and redraws the bar (the loggers of common::NamedLogger
/// print through it).
///
/// Silent when the descriptor is not a terminal (a pipe, a file, CI) or when
/// the command was given --quiet. No allocation after construction: Update
/// reads the clock and, when a redraw is due, formats into a fixed buffer
/// and write(2)s it.

#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <thread>

namespace rocklab::common {

class Progress {
 public:
  /// `label`: a short word, kept by pointer (a string literal). `total`:
  /// the input's size, bytes (<= 0: unknown, the bar shows bytes read
  /// only). Draws on `fd` only when `isatty(fd)` and !quiet.
  /// `unit` (a string literal): counted items, e.g. "rows"; null: bytes.
  Progress(const char* label, std::int64_t total, bool quiet, int fd = 2, const char* unit = nullptr);
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
  /// Items that were done before this run began (a resumed sweep): left
  /// out of the rate.
  void SetBase(std::int64_t done_before) { base_ = done_before; }

  /// Runs `print` (which writes whole lines to `fd`) with the bar drawn on
  /// `fd`, if any, cleared first and redrawn after; serialised with the
  /// bars' redraws (any thread).
  static void PrintAbove(int fd, const std::function<void()>& print);

  /// The bar's text (no `\r`) into `out` (at most `size` bytes with the
  /// NUL): label, bar of `width` cells, percent, rate (B/s, kB/s, MB/s,
  /// GB/s), time left (m:ss, or h:mm:ss). `elapsed_s` <= 0 or nothing
  /// done: no rate, "--:--" left. Returns the length written.
  /// With `unit`, counts instead of bytes ("120/600 rows  3.2 rows/s");
  /// `base`: items done before the start, left out of the rate.
  static std::size_t Format(char* out, std::size_t size, const char* label, std::int64_t done,
                            std::int64_t total, double elapsed_s, int width = 20, const char* unit = nullptr,
                            std::int64_t base = 0);

 private:
  void DrawLocked();  // with the drawing lock held

  const char* label_;
  std::int64_t total_;
  int fd_;
  const char* unit_;
  std::int64_t base_{0};
  bool active_{false};
  std::size_t line_size_{0};  // of the last line drawn, 0: none
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
