#pragma once
/// @file
/// Raw sample sources behind one interface: CSV, LabVIEW .lvm and rocklab LCM
/// logs (RL_RAW), and the live ones: a CSV/LVM followed as it is written, a
/// TCP stream of CSV lines, raw_frame_t from another program over LCM
/// (docs/daq-inputs.md). Opening a source reads its header and throws on anything
/// that stops the read. Afterwards a malformed row is reported to the problem
/// callback with its file and line, counted, and skipped (its sample number
/// stays unused, so it shows downstream as a gap), and a malformed value in a
/// good row becomes NaN (a counted bad sample). Next() never throws: when the
/// read cannot go on or has nothing to show (text sources: a read error of
/// the file, never taken for its end; the end of a file none of whose data
/// rows could be used) it returns ReadStatus::kError, the message (naming
/// the file) goes to the problem callback and stays in error(). Messages quote input through a bounded, escaped
/// excerpt (detail::Quote): no raw bytes, no NUL, at most 48 bytes of a field.

#include <atomic>
#include <cstdint>
#include <functional>
#include <istream>
#include <memory>
#include <string>
#include <vector>

namespace rocklab::daq {

struct RigConfig;

/// Where something happened in an input: "file:line" (LCM logs: the event
/// number stands in for the line).
struct Location {
  const std::string* file{};  ///< non-owning; outlives the report
  int64_t line{};
};

/// A problem on the streaming path that did not stop the read.
struct Problem {
  Location where;
  std::string message;  ///< one line, without the location
};
/// Receives problems; called on the reading thread. Must not throw.
using ProblemCallback = std::function<void(const Problem&)>;
/// "file:line: message".
std::string ToString(const Problem& problem);

/// One acquired sample of every channel, before calibration.
struct Frame {
  int64_t seq{};        ///< sample number on the acquisition clock; gaps mean lost samples
  double time_s{};      ///< acquisition sample clock, s
  int64_t line{};       ///< line (LCM: event number) in the source
  std::vector<double> values;  ///< raw values in channel_names() order; NaN where missing
  std::string comment;  ///< LVM: the row's Comment text (UTF-8), usually empty
  /// Sample clock in integer microseconds (rounded), as carried by every message.
  int64_t utime() const;
};

enum class ReadStatus {
  kFrame,  ///< `frame` holds the next sample
  kEnd,    ///< no more samples
  kError,  ///< the read cannot go on: Source::error() says why, naming the file
  kIdle,   ///< live sources only: nothing arrived within 0.1 s; call again
};

/// Counters a source keeps while reading.
struct SourceStats {
  int64_t rows{};         ///< data rows (LCM: RL_RAW events) seen
  int64_t bad_rows{};     ///< rows skipped (ragged, no time, undecodable)
  int64_t bad_values{};   ///< values that are not numbers (delivered as NaN)
  int64_t warnings{};     ///< other problems (e.g. LVM Samples disagreeing with the rows)
  int64_t segments{};     ///< LVM: segment headers read (CSV, LCM: 0)
  int64_t damaged_regions{};  ///< LCM logs: damaged regions skipped (bad sync, length, cut tail)
  int64_t damaged_bytes{};    ///< LCM logs: bytes in them
  int64_t damaged_events{};   ///< LCM logs: events lost in them
  int64_t empty_values{};     ///< empty fields (delivered as NaN; the first of each column reported)
  int64_t comments{};         ///< LVM rows with Comment text (kept in Frame::comment)
  int64_t restarts{};         ///< live: reconnections (TCP), files replaced or truncated (--follow)
  int64_t restart_lost{};     ///< live: samples lost across restarts, from the time column
  int64_t x_disagreements{};  ///< LVM X_Columns Multi: rows whose X columns disagree
};

class Source {
 public:
  virtual ~Source() = default;
  /// Channel names in frame order (without the time column).
  virtual const std::vector<std::string>& channel_names() const = 0;
  /// The unit of each channel's values as the file states it (LVM:
  /// Y_Unit_Label of the first segment), in channel_names() order, "" where
  /// it states none; empty when the format carries no units (CSV, LCM).
  /// These are the units of the raw values, before the rig's calibration.
  virtual std::vector<std::string> channel_units() const { return {}; }
  /// Whether frames may carry Frame::comment (LVM with a Comment column in
  /// its first segment).
  virtual bool has_comments() const { return false; }
  /// Nominal sample rate, Hz (from the file's time base where it has one).
  virtual double sample_rate_hz() const = 0;
  /// Reads the next frame into `frame`, reusing its storage. Never throws
  /// (but common::ReadCancelled, the stop of a caller that set a
  /// common::ThreadCancelScope on this thread: Python's Ctrl-C);
  /// kError when the read cannot go on (see the top of this file), and
  /// kError again on every later call.
  [[nodiscard]] virtual ReadStatus Next(Frame& frame) = 0;
  virtual const SourceStats& stats() const = 0;
  virtual const std::string& path() const = 0;
  /// Live sources (tcp://, lcm://, --follow): frames arrive on their own
  /// clock, so they are not paced, and Next() may return kIdle.
  virtual bool live() const { return false; }
  /// After kError: why, "file[:line]: ..."; empty before.
  const std::string& error() const { return error_; }
  /// The source's own counts for the end of a read, one line (a video's
  /// tracker: frames, drops, LED samples missing, merged, ...); empty when
  /// it has none beyond stats().
  virtual std::string summary() const { return {}; }

 protected:
  std::string error_;
};

struct SourceOptions {
  /// The sample rate, Hz: needed for a file without a time column or time
  /// base, and for live inputs; 0 = take it from the file's time column.
  /// Where the file has a time column or time base too, the two must agree
  /// within 0.1 % (a source refuses the file otherwise, naming both).
  double sample_rate_hz{};
  /// Where sample_rate_hz came from, for that message: the rig's for the
  /// DAQ, reconstruct and run; "--rate" or "rate=" for export and info.
  std::string rate_origin{"the rig's sample_rate_hz"};
  /// LCM logs: channel of the raw frames and of their description.
  std::string raw_channel{"RL_RAW"};
  std::string config_channel{"RL_DAQ_CONFIG"};
  /// LCM logs without an RL_DAQ_CONFIG event: channel names to assume.
  std::vector<std::string> fallback_channel_names;
  ProblemCallback on_problem;  ///< may be empty
  /// CSV field separator: ',', ';' or '\t'; 0 = sniffed from the header line.
  /// With ';' or tab a decimal comma in the numbers is accepted.
  char delimiter{0};
  /// CSV and LVM files: keep reading as the file grows (a live source).
  bool follow{false};
  /// Live sources end after this long without data, s; 0 = never.
  double idle_timeout_s{0};
  /// Live sources end once *stop is true (also while waiting for a header).
  /// Non-owning, may be null; must outlive the source.
  const std::atomic<bool>* stop{};
  /// Live text sources (tcp://, tcp-listen://, --follow): called every wait
  /// slice (0.1 s) while they wait for a header, at the open and after a
  /// restart, on the reading thread (the DAQ node's heartbeat). May be
  /// empty; must not throw.
  std::function<void()> on_wait;
  /// lcm:// sources: the LCM URL to subscribe on (empty: LCM's default).
  std::string lcm_url;
  /// Inputs read through the rig (video:, v4l2:): the rig loaded. Non-owning,
  /// may be null; must outlive the source.
  const RigConfig* rig{};
};

/// CSV with a header row; a `time` column (s) if present, else time = seq / rate.
/// With a time column and no rate given, the rate is the time column's (its
/// first 256 rows; a file only, a live input needs the rate).
/// A UTF-8 byte order mark before the header is ignored. Times must lie in
/// [-1e12, 1e12] s (a row outside is skipped); a line longer than 1 MiB is
/// skipped as a bad row.
/// @throws std::runtime_error (naming the file and line) when the file cannot be
///         opened, is empty, or its header is unusable.
std::unique_ptr<Source> OpenCsvSource(const std::string& path, const SourceOptions& options);
/// LabVIEW Measurement file (what is read: docs/acquisition.md).
/// @throws std::runtime_error (file:line) as OpenCsvSource.
std::unique_ptr<Source> OpenLvmSource(const std::string& path, const SourceOptions& options);
/// LCM log with raw_frame_t events on options.raw_channel.
/// @throws std::runtime_error when the log cannot be opened or names no channels.
std::unique_ptr<Source> OpenLcmLogSource(const std::string& path, const SourceOptions& options);
/// The same readers over any stream (tests, fuzzing); `name` stands for the
/// file in messages.
std::unique_ptr<Source> OpenCsvStream(std::unique_ptr<std::istream> in, const std::string& name,
                                      const SourceOptions& options);
std::unique_ptr<Source> OpenLvmStream(std::unique_ptr<std::istream> in, const std::string& name,
                                      const SourceOptions& options);
/// A CSV stream from an acquisition PC: tcp://HOST:PORT (a header line, then
/// one line per sample), reconnecting with backoff; samples lost across a
/// reconnection are counted from the time column (SourceStats::restart_lost).
/// With `listen` (tcp-listen://HOST:PORT) the DAQ listens and the
/// acquisition PC connects (LabVIEW's TCP Open Connection); the same
/// reconnection rules hold.
/// A row broken off by a dropped connection (or left unfinished at the
/// stop or the idle timeout) is no sample: counted as a bad row, reported.
/// @throws std::invalid_argument on a malformed address; std::runtime_error
///         when no header arrived before the stop or the idle timeout (an
///         "incomplete header" when only part of one did), or when it
///         cannot listen.
std::unique_ptr<Source> OpenTcpSource(const std::string& host_port, const SourceOptions& options,
                                      bool listen = false);
/// raw_frame_t messages from another program on `channel` of options.lcm_url;
/// values in the order of options.fallback_channel_names (the rig's channels).
/// @throws std::invalid_argument when `channel` is options.raw_channel (the
///         DAQ republishes there) or empty; std::runtime_error when LCM fails.
std::unique_ptr<Source> OpenLcmLiveSource(const std::string& channel, const SourceOptions& options);
/// By form: tcp://HOST:PORT, tcp-listen://HOST:PORT, lcm://CHANNEL, a registered
/// form (below); else by extension: .csv, .lvm (followed when options.follow),
/// anything else is read as an LCM log.
/// @throws std::invalid_argument for video: or v4l2: when no opener is registered
///         (a build without video/).
std::unique_ptr<Source> OpenSource(const std::string& path, const SourceOptions& options);

/// Opens an input of a form daq does not read itself; `spec` without the prefix.
using SourceOpener = std::unique_ptr<Source> (*)(const std::string& spec, const SourceOptions& options);
/// Makes OpenSource open inputs starting with `prefix` ("video:", "v4l2:")
/// through `opener`: the seam of libraries daq does not link (video/). Call
/// at start-up, before any OpenSource on another thread.
void RegisterSourceForm(const std::string& prefix, SourceOpener opener);

}  // namespace rocklab::daq
