#pragma once
/// @file
/// The lab's LCM recorder (`rocklab record`): loses nothing it can avoid and
/// counts what it cannot.
///
/// Threading model. LCM's dispatch thread (the caller's, which runs
/// lcm.handle*) only copies each event into a bounded EventQueue (one
/// allocation at start, no blocking, no I/O); a writer thread takes the
/// queued events in batches and writes them, in receipt order, to the LCM log
/// (rotating it by size or time), flushing it at most 100 ms after an event
/// (stdio buffers 1 MiB in between). When the queue is full the event is dropped and counted for its
/// channel (a warning at most once a second is the caller's: DropsSince()).
/// Shutdown order (Stop): unsubscribe, close the queue, the writer writes
/// everything queued, flushes and closes the file, the thread is joined.
///
/// Where loss can still happen, and how it shows:
/// - the kernel's socket buffer (udpm): ask for a large one with the URL's
///   recv_buf_size (capped by net.core.rmem_max); invisible to the recorder,
///   except through sequence numbers (below);
/// - LCM's per-subscription queue: raised to `lcm_queue_messages`;
/// - the recorder's queue: counted per channel (`dropped`);
/// - write errors: counted per channel (`dropped`) with the error logged;
/// - a queue whose memory a bug damaged: the events given up counted in the
///   total `dropped` and `queue_damaged_events` (not per channel: a damaged
///   record does not say its channel), with the error logged.
/// Channels whose type carries a sequence number right after utime (every
/// current rocklab type, recognised by its LCM fingerprint: common::WireSeq)
/// are checked: `seq_gaps` jumps forward, `seq_missing` the numbers skipped,
/// `seq_back` numbers that went back or repeated; on RL_EVENT and RL_HEALTH
/// per sender (each node numbers its own), summed. A gap at the source (a
/// DAQ that lost samples) shows the same way. Older types (logs replayed
/// from before) carry none and are not checked.

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>
#include <unordered_map>
#include <utility>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include "common/versions.h"
#include "record/event_queue.h"
#include "record/log_provenance.h"
#include "record/log_writer.h"

namespace rocklab::record {

struct RecorderOptions {
  std::string out_path;            ///< the log (or the rotated series' base name)
  std::string channels{".*"};      ///< LCM channel regex, matched against the whole name
  int64_t rotate_bytes{0};         ///< bytes per file, 0: no size rotation
  double rotate_seconds{0};        ///< s per file, 0: no time rotation
  bool overwrite{false};           ///< replace existing files
  /// The recorder's queue, bytes: 64 MiB holds ~40 s of a 1 kHz test with
  /// every channel and four model variants (~1.6 MB/s), time for a stalled
  /// disk or a starved writer thread to come back. Pages are touched only as
  /// the queue first fills.
  std::size_t queue_bytes{64u << 20};
  /// LCM's own queue per subscription, messages (LCM's default of 30 drops
  /// silently after 30 ms of a 1 kHz stream if this thread is held up).
  int lcm_queue_messages{1 << 20};
  /// Writes each finished file's provenance sidecar (not owned; outlives the
  /// Recorder); null: none. Called on the writer thread, never LCM's.
  LogProvenance* provenance{nullptr};
  /// @throws std::invalid_argument naming the option.
  void Validate() const;
};

struct ChannelStats {
  std::string name;
  int64_t received{};     ///< events LCM handed to the recorder
  int64_t count{};        ///< events written to the log
  int64_t bytes{};        ///< payload bytes written
  int64_t dropped{};      ///< received but not written (queue full, write error)
  /// Sequence numbers (JSON seq_gaps, seq_missing, seq_back); `seq.any`:
  /// the type carries one (JSON has_seq).
  common::ChannelSeqGaps seq;
};

struct RecorderStats {
  std::vector<ChannelStats> channels;  ///< in order of first receipt
  std::vector<std::string> files;      ///< log files, in order
  int64_t received{};
  int64_t events{};    ///< written
  int64_t dropped{};
  int64_t bytes{};     ///< log bytes written
  std::size_t queue_bytes{};
  std::size_t queue_high_water_bytes{};
  /// Events the queue gave up on finding its memory damaged (in `dropped`
  /// too; EventQueue::damage()).
  int64_t queue_damaged_events{};
  std::string write_error;  ///< the first write error, if any
};

class Recorder {
 public:
  /// Subscribes `lcm` (not owned; must outlive the Recorder, and be handled
  /// by one thread) and opens the first file.
  /// @throws std::invalid_argument for bad options, std::runtime_error when
  ///         the log cannot be created (naming it).
  Recorder(lcm::LCM& lcm, RecorderOptions options);
  /// As above on several LCM instances (the main bus and RL_RAW's own,
  /// common/bus_urls.h), the same channel regex on each, into one log: all
  /// handled by the same one thread, so the log is in the order that thread
  /// received the events; a channel's counts add up over the instances.
  Recorder(const std::vector<lcm::LCM*>& lcms, RecorderOptions options);
  ~Recorder();
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;

  /// Unsubscribes, writes what is queued, closes the file. Idempotent. Call
  /// from the thread that handles the LCM instances.
  void Stop();

  /// Events dropped since the counter was last read (for a rate-limited
  /// warning; call from the thread that handles `lcm`).
  int64_t DropsSince();

  /// The counts; complete after Stop. Call from the thread that handles `lcm`.
  RecorderStats Stats() const;

 private:
  static void OnMessage(const lcm::ReceiveBuffer* rbuf, const std::string& channel, Recorder* self);
  void WriterLoop();

  struct ProducerChannel {
    int64_t received{};
    int64_t dropped{};
  };

  RecorderOptions options_;
  // Each LCM instance (not owned) and the recorder's subscription on it.
  std::vector<std::pair<lcm::LCM*, lcm::Subscription*>> subscriptions_;
  EventQueue queue_;
  RotatingLogWriter writer_;  // the writer thread's after construction
  // LCM's thread: channel ids and receipt counts.
  std::unordered_map<std::string, int32_t> ids_;
  std::vector<std::string> names_;
  std::vector<ProducerChannel> produced_;
  int64_t drops_reported_{0};
  int64_t drops_total_{0};
  int64_t unregistered_drops_{0};  // events of a channel that could not be added
  // The writer thread's: counts and sequence state per channel id.
  std::vector<ChannelStats> written_;
  std::atomic<int64_t> write_failures_{0};
  std::thread thread_;
  bool stopped_{false};
};

/// The summary as JSON text (keys in docs/commands.md, `rocklab record`: files, events, received,
/// dropped, bytes, queue_bytes, queue_high_water_bytes, write_error, and
/// channels: name, count, received, dropped, bytes, seq_gaps, seq_missing,
/// seq_back, with has_seq).
std::string SummaryJson(const RecorderStats& stats);

}  // namespace rocklab::record
