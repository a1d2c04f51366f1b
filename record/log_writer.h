#pragma once
/// @file
/// LCM log files written directly (the format of LCM's eventlog: each event
/// is the sync word 0xEDA1DA01, int64 event number, int64 timestamp (us),
/// int32 channel length, int32 payload length, the channel, the payload; all
/// integers big-endian), one file or a rotated series.
/// Self-contained on purpose: it can move to common/ with a shared log writer.

#include <cstdint>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace rocklab::record {

/// One LCM log file being written.
class LogFileWriter {
 public:
  /// Creates `path`. Without `overwrite` an existing file is an error.
  /// @throws std::runtime_error naming the path when it cannot be created.
  LogFileWriter(const std::string& path, bool overwrite);
  ~LogFileWriter();
  LogFileWriter(const LogFileWriter&) = delete;
  LogFileWriter& operator=(const LogFileWriter&) = delete;

  /// Appends one event (buffered). False on a write error (see error()).
  [[nodiscard]] bool Write(int64_t event_number, int64_t utime, std::string_view channel, const uint8_t* data,
                           uint32_t size);
  /// Hands the buffered bytes to the kernel. False on a write error.
  [[nodiscard]] bool Flush();
  /// Flushes and closes; false on a write error. Idempotent.
  [[nodiscard]] bool Close();

  const std::string& path() const { return path_; }
  /// Bytes written to this file so far (buffered included).
  int64_t bytes() const { return bytes_; }
  int64_t events() const { return events_; }
  const std::string& error() const { return error_; }

  /// Bytes an event takes in a log: 28 + channel + payload.
  static int64_t EventBytes(std::size_t channel_size, std::size_t data_size) {
    return 28 + static_cast<int64_t>(channel_size) + static_cast<int64_t>(data_size);
  }

 private:
  void Fail(const char* what);
  std::string path_;
  std::FILE* file_{};
  std::vector<char> buffer_;  // stdio's buffer, 1 MiB
  int64_t bytes_{};
  int64_t events_{};
  std::string error_;
};

/// A file of a recording, closed without a write error: what its provenance
/// sidecar says of it (record/log_provenance.h).
struct FinishedLogFile {
  std::string path;
  int index{};               ///< its place in the series, from 0 (0 without rotation)
  int64_t first_event{};     ///< the event number of its first event
  int64_t events{};          ///< events in it
  int64_t bytes{};           ///< its size, bytes
  int64_t first_utime{};     ///< its first event's timestamp, us (0 when empty)
  int64_t last_utime{};      ///< its last event's timestamp, us (0 when empty)
};

/// Where and when a recording goes to a new file.
struct RotationOptions {
  std::string path;           ///< the log; with rotation, the series' base name (RotatedPath)
  int64_t rotate_bytes{0};    ///< start a new file before one would pass this size, bytes; 0: never
  double rotate_seconds{0};   ///< start a new file when an event is this long after the file's first, s; 0: never
  bool overwrite{false};      ///< replace existing files instead of refusing them
  /// Called, on the writing thread, with each file's path once it is
  /// created, and with each file once it is closed without error (at a
  /// rotation and at Close); not for a file whose close failed. Must not
  /// throw. Empty: nothing.
  std::function<void(const std::string& path)> on_started;
  std::function<void(const FinishedLogFile& file)> on_finished;
  /// @throws std::invalid_argument naming the option (rotate-size, rotate-seconds).
  void Validate() const;
  bool rotates() const { return rotate_bytes > 0 || rotate_seconds > 0; }
};

/// File `index` of a rotated series: "test.lcm" -> "test.0000.lcm",
/// "test.0001.lcm", ...; a name without an extension gets ".0000" appended.
std::string RotatedPath(const std::string& path, int index);

/// Writes a recording, in order, to one file or to a rotated series. Event
/// numbers count every event of the recording (they continue across files,
/// so a missing file shows), timestamps never decrease (an event received
/// with an earlier host time than the one before gets the one before's).
class RotatingLogWriter {
 public:
  /// Opens the first file.
  /// @throws std::invalid_argument for bad options, std::runtime_error when
  ///         the first file cannot be created (naming it).
  explicit RotatingLogWriter(RotationOptions options);
  /// Appends one event, first starting a new file when a limit says so.
  /// False on a write or open error (see error()); the event is not written.
  [[nodiscard]] bool Write(int64_t utime, std::string_view channel, const uint8_t* data, uint32_t size);
  [[nodiscard]] bool Flush();
  /// Flushes and closes the current file; false on a write error.
  [[nodiscard]] bool Close();

  /// Every file started, in order.
  const std::vector<std::string>& files() const { return files_; }
  int64_t events() const { return next_event_; }
  int64_t bytes() const { return bytes_done_ + (file_ ? file_->bytes() : 0); }
  const std::string& error() const { return error_; }

 private:
  bool Open(int index);
  /// Closes the current file (adding its bytes); calls on_finished when it closed well.
  bool CloseFile();
  RotationOptions options_;
  std::unique_ptr<LogFileWriter> file_;
  std::vector<std::string> files_;
  int64_t next_event_{0};
  int64_t last_utime_{INT64_MIN};
  int64_t file_first_utime_{0};
  int64_t bytes_done_{0};
  std::string error_;
};

}  // namespace rocklab::record
