#pragma once
/// @file
/// The one LCM log reader and the one writer of rocklab (every command that
/// reads or writes a log goes through them).
///
/// The format (LCM's, also lcm-logger's): events back to back, each
///   uint32 sync word 0xEDA1DA01, int64 event number, int64 timestamp (us),
///   int32 channel length, int32 data length, channel bytes, data bytes,
/// all integers big-endian.
///
/// LogReader reads in file order with buffered streaming I/O (never by
/// bisection on the timestamps: rocklab logs written before the writer kept
/// its stamps in order, and logs of several hosts, have stamps that go back).
/// A damaged region (a bad sync word, an impossible length, a cut tail) is
/// skipped by scanning for the next plausible event header; it is counted
/// (bytes and events) and reported once to the problem callback with its file
/// offset. Lengths are checked against fixed bounds and the file's size
/// before any allocation. Opening throws; afterwards nothing throws.
///
/// LogWriter writes events with timestamps that never go back: each event's
/// stamp is max(the stamp asked for, the previous event's stamp).

#include <cstdint>
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace rocklab::common {

/// The sync word that starts every event of an LCM log.
inline constexpr std::uint32_t kLcmLogSync = 0xEDA1DA01u;

/// One event as read. `data` is reused by the reader (its capacity kept).
struct LogEvent {
  std::int64_t number{};        ///< event number as written
  std::int64_t timestamp_us{};  ///< the writer's stamp, us
  std::int64_t offset{};        ///< file offset of its sync word, bytes
  std::string channel;
  std::vector<std::uint8_t> data;
};

/// A damaged region of a log that the reader skipped.
struct LogProblem {
  std::string file;
  std::int64_t offset{};  ///< file offset where the damage starts, bytes
  std::int64_t bytes{};   ///< bytes skipped
  std::int64_t events{};  ///< events lost in it (from the event numbers around it; >= 1)
  std::string what;       ///< one line: what was wrong there
};
/// "file: damaged region at byte offset N (B bytes, E events skipped): what".
std::string ToString(const LogProblem& problem);

struct LogReaderOptions {
  std::string channels{".*"};  ///< ECMAScript regex matched against the whole channel name
  /// Window, s after the first event's timestamp: events stamped before
  /// start_s or after end_s are read and left out (counted). start_s = 0
  /// leaves nothing out at the start; end_s < 0: no end.
  double start_s{0.0};
  double end_s{-1.0};
  /// The read stops at the first event stamped more than this after the
  /// window's end (events of a log are at most a few samples out of order;
  /// reading on to the end of a long log for a short window costs seconds).
  double end_slack_s{10.0};
  std::int32_t max_channel_bytes{256};        ///< longer channel names are damage
  std::int32_t max_data_bytes{256 << 20};     ///< larger payloads are damage, bytes
  /// Receives each damaged region once (the first pass that reads it);
  /// called on the reading thread; must not throw. Empty: counted only.
  std::function<void(const LogProblem&)> on_problem;
  /// @throws std::invalid_argument naming the option.
  void Validate() const;
};

/// What a reader has read so far (all passes).
struct LogReadCounts {
  std::int64_t events{};           ///< well-formed events read
  std::int64_t delivered{};        ///< events returned by Next
  std::int64_t filtered{};         ///< left out by the channel regex
  std::int64_t outside_window{};   ///< left out by the window
  std::int64_t damaged_regions{};  ///< regions skipped (each reported once)
  std::int64_t damaged_bytes{};    ///< bytes in them
  std::int64_t damaged_events{};   ///< events lost in them
};

class LogReader {
 public:
  /// Opens `path` and reads its first event (the window's time origin).
  /// @throws std::runtime_error naming the file when it cannot be opened, is
  ///         a folder, or holds no readable event.
  explicit LogReader(const std::string& path, LogReaderOptions options = {});
  ~LogReader();
  LogReader(const LogReader&) = delete;
  LogReader& operator=(const LogReader&) = delete;

  /// The next event of the window that passes the channel filter, in file
  /// order; false at the end. Never throws.
  [[nodiscard]] bool Next(LogEvent& event);
  /// The timestamp of the event Next would return, us; INT64_MAX at the end.
  std::int64_t NextEventTimeUs();
  /// Starts the window again (a replay's next --loop pass): from the first
  /// event of the window, or the start of the file before one was found.
  void Rewind();

  const LogReadCounts& counts() const;
  /// The first event's timestamp: the window's origin, us.
  std::int64_t first_timestamp_us() const;
  const std::string& path() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// True when `path` starts with the LCM sync word (an LCM log).
bool StartsWithLcmSync(const std::string& path);

/// Writes an LCM log. Events are gathered in a 1 MiB buffer of whole events
/// and written with write(2) when it fills and at Close: an event is counted
/// either as written (events()) or as lost (write_errors()), never both, so
/// on a full disk (`--log /dev/full`) write_errors() is the number of events
/// that are not in the file. (A buffer cut short by the disk leaves a
/// damaged tail the reader skips and counts.)
class LogWriter {
 public:
  /// Creates (truncates) `path`.
  /// @throws std::runtime_error naming the file when it cannot be created.
  explicit LogWriter(const std::string& path);
  /// Flushes and closes (errors are counted in write_errors()).
  ~LogWriter();
  LogWriter(const LogWriter&) = delete;
  LogWriter& operator=(const LogWriter&) = delete;

  /// Appends one event stamped max(timestamp_us, the previous stamp), us.
  /// @return false when the event (or the buffer it filled) could not be
  ///         written (counted). Never throws.
  bool Write(const std::string& channel, const void* data, std::size_t size,
             std::int64_t timestamp_us);
  /// Writes what is buffered and closes the file; false on an error (the
  /// buffered events counted as lost). Idempotent.
  bool Close();

  /// Events taken (in the file, or buffered for it) and not lost.
  std::int64_t events() const { return events_; }
  /// Events that could not be written: lost, not in the file.
  std::int64_t write_errors() const { return write_errors_; }
  /// Events whose asked-for stamp was earlier than the previous one's.
  std::int64_t raised_stamps() const { return raised_stamps_; }
  const std::string& path() const { return path_; }
  /// The first write error's reason (strerror), empty when none.
  const std::string& error() const { return error_; }

 private:
  bool Flush();

  std::string path_;
  int fd_{-1};
  std::vector<char> buffer_;  // whole events, at most kBufferBytes unless one event is larger
  std::int64_t buffered_events_{};
  std::int64_t next_number_{};  // the event number the next event carries
  std::int64_t last_stamp_{INT64_MIN};
  std::int64_t events_{}, write_errors_{}, raised_stamps_{};
  std::string error_;
};

}  // namespace rocklab::common
