#pragma once
/// @file
/// The provenance of an LCM log series (`daq --log`, `record`): one sidecar
/// per finished file, FILE.provenance.csv (common::WriteProvenanceSidecarFields,
/// as `run --log` has it), written whole when the file is closed or rotated,
/// so every file of a rotated series carries its own and a crash leaves the
/// file being written without one (never half of one). The log's bytes stay
/// as every reader expects them.
///
/// Cost: the sources are hashed once, on a thread of their own from
/// construction (common::MakeProvenance), and each sidecar is written (and
/// synced) on that thread too, in the order the files finish: the writing
/// thread (the DAQ's, at a rotation) only queues the file's counts. Per
/// file, one sidecar of a few hundred bytes; nothing per event. The
/// sidecars are on disk once errors() or Drain() returns, or the object is
/// destroyed.

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <ctime>
#include <deque>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "common/provenance.h"
#include "record/log_writer.h"

namespace rocklab::record {

class LogProvenance {
 public:
  using Fields = std::vector<std::pair<std::string, std::string>>;
  /// `sources`: files hashed (common::MakeProvenance: empty paths left out,
  /// live inputs listed as "could not be read"); `extra`: rows after the
  /// common ones (rig, lcm_url, ...), before each file's own.
  LogProvenance(std::vector<std::string> sources, Fields extra);
  ~LogProvenance();  ///< writes the sidecars still queued, then joins its thread
  LogProvenance(const LogProvenance&) = delete;
  LogProvenance& operator=(const LogProvenance&) = delete;

  /// Hooks `options` (on_started, on_finished) to this object, which must
  /// outlive the writer. `series` names the recording (the --log/LOG path).
  void Attach(RotationOptions& options);

  /// Returns when every file finished so far has its sidecar written (or
  /// counted in errors()).
  void Drain();

  /// Sidecars that could not be written (each logged with its reason), of
  /// every file finished so far (drains first).
  int64_t errors();

 private:
  struct Queued {
    FinishedLogFile file;
    std::time_t finished{};  // created_utc: when the file was finished
  };
  void Started(const std::string& path);
  void Finished(const FinishedLogFile& file);
  void Work(std::vector<std::string> sources);
  /// The sidecar rows of `file`: rocklab_version, build_type, command,
  /// created_utc, source_N, the extra rows, then log_series,
  /// log_file_index, first_event, events, bytes, first_utime_us,
  /// last_utime_us.
  Fields FieldsOf(const Queued& q);

  std::mutex mutex_;
  std::condition_variable wake_;     // the worker: a file queued, or stopping
  std::condition_variable drained_;  // Drain: the queue emptied
  std::deque<Queued> queue_;         // guarded by mutex_
  bool busy_{false};                 // the worker is writing one (mutex_)
  bool stopping_{false};             // (mutex_)
  bool have_provenance_{false};      // (mutex_)
  common::Provenance provenance_;    // the worker's hashing, once done (mutex_)
  Fields extra_;
  std::string series_;
  std::atomic<int64_t> errors_{0};
  std::thread worker_;  // last: started once the members above exist
};

}  // namespace rocklab::record
