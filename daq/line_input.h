#pragma once
// Private to rocklab::daq: where the text sources (CSV, LVM) get their lines.
// A stream read to its end, a file followed as it grows (--follow), or a TCP
// connection to an acquisition PC (tcp://HOST:PORT). All read blocks and
// split them in place (no copy of a line that lies within one block); the
// live inputs take what has arrived, so a line is delivered as soon as its
// '\n' is there, never held back for a full block. The live inputs wait in
// slices of at most kIdleSliceMs so the caller can check its stop flag and
// publish its heartbeat while nothing arrives.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <istream>
#include <memory>
#include <string>
#include <string_view>

namespace rocklab::daq::detail {

enum class LineStatus {
  kLine,     ///< `line` holds the next line, without its '\n'
  kEnd,      ///< no more lines (end of a plain file; stop; idle timeout)
  kIdle,     ///< nothing complete arrived within one wait slice (live inputs, may_idle only)
  kRestart,  ///< the input started over (file replaced or truncated, reconnected): a header comes next
  /// Live inputs only: `line` holds the start of a line the input broke off
  /// before its '\n' (a dropped connection, a replaced or rewritten file,
  /// the stop or the idle timeout). Never a whole row: the reader counts it.
  kCut,
};

/// How long a live input waits for data before returning kIdle, ms.
inline constexpr int kIdleSliceMs = 100;

struct LiveOptions {
  const std::atomic<bool>* stop{};  ///< non-owning, may be null: kEnd once it is true
  double idle_timeout_s{};          ///< kEnd after this long without a byte; 0 = never
};

class LineInput {
 public:
  virtual ~LineInput() = default;
  /// Reads the next line: `line` views it, without its '\n', and stays
  /// valid until the next Read (it points into the input's block buffer, or
  /// into a carry-over buffer for a line that straddles two blocks). A line
  /// longer than `max_bytes` is cut there and `too_long` set (the rest is
  /// skipped); memory stays bounded by the block and `max_bytes`.
  /// With may_idle false a live input blocks until a line, the stop or the
  /// idle timeout; with may_idle true it returns kIdle after one slice.
  /// A partial last line (no '\n') is delivered when the input ends: as
  /// kLine by a plain file or stream, as kCut by a live input (whose last
  /// line was still being written).
  /// @throws std::runtime_error with the cause of a read error (never taken
  ///         for the end of the input); the reader adds the file and line.
  virtual LineStatus Read(std::string_view& line, bool& too_long, std::size_t max_bytes, bool may_idle) = 0;
  /// Whether the input is live (followed file, TCP): no pacing, kIdle possible.
  virtual bool live() const { return false; }
  /// Times the input started over (kRestart returned).
  int64_t restarts() const { return restarts_; }

 protected:
  int64_t restarts_{0};
};

/// Bytes a plain file or stream is read by at a time: large enough that the
/// read calls and the carry-over of the line cut at a block's end cost
/// nothing per line, small enough for any host (one buffer per source).
inline constexpr std::size_t kBlockBytes = std::size_t{256} << 10;

/// Lines of `in` to its end, read in blocks of kBlockBytes (tests, fuzzing).
std::unique_ptr<LineInput> StreamLines(std::unique_ptr<std::istream> in);
/// Lines of the file at `path` to its end, read with read(2) in blocks of
/// kBlockBytes (the plain CSV/LVM readers).
/// @throws std::runtime_error "PATH: cannot open the input file" when it cannot be opened.
std::unique_ptr<LineInput> FileLines(const std::string& path);
/// Lines of the file at `path`, followed as it grows: a partial last line
/// waits for its '\n'; a file replaced at `path` (another inode), truncated
/// (shorter than what was read) or written again from its start (its first
/// bytes, or the bytes just before the read position, changed: a truncation
/// and rewrite in one write never shows a shorter file) is read from its
/// start after the old one's last byte (kRestart).
/// @throws std::runtime_error when the file cannot be opened.
std::unique_ptr<LineInput> FollowFile(const std::string& path, const LiveOptions& options);
/// Lines from a TCP server at host:port; reconnects with a backoff of 0.1 s
/// doubling to 5 s after a refused connection or a closed one (kRestart
/// after every reconnection). The first connection is tried at the first
/// Read, so a server started after the DAQ is fine.
/// With `listen`, it listens on host:port instead (host empty or "*": every
/// address) and takes one connection at a time from the acquisition PC.
/// @throws std::invalid_argument when `host_port` is not HOST:PORT;
///         std::runtime_error when it cannot listen there.
std::unique_ptr<LineInput> TcpLines(const std::string& host_port, const LiveOptions& options, bool listen = false);

}  // namespace rocklab::daq::detail
