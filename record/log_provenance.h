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
/// construction (common::MakeProvenance); the writing thread waits for them
/// only at the first finished file. Per file, one sidecar of a few hundred
/// bytes; nothing per event.

#include <atomic>
#include <cstdint>
#include <future>
#include <string>
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
  ~LogProvenance();  ///< waits for the hashing thread
  LogProvenance(const LogProvenance&) = delete;
  LogProvenance& operator=(const LogProvenance&) = delete;

  /// Hooks `options` (on_started, on_finished) to this object, which must
  /// outlive the writer. `series` names the recording (the --log/LOG path).
  void Attach(RotationOptions& options);

  /// The sidecar rows of `file`: rocklab_version, build_type, command,
  /// created_utc (the time the file was finished), source_N, the extra
  /// rows, then log_series, log_file_index, first_event, events, bytes,
  /// first_utime_us, last_utime_us.
  Fields FieldsOf(const FinishedLogFile& file);

  /// Sidecars that could not be written (each logged with its reason).
  int64_t errors() const { return errors_.load(); }

 private:
  void Started(const std::string& path);
  void Finished(const FinishedLogFile& file);
  std::future<common::Provenance> hashing_;
  common::Provenance provenance_;  // hashing_'s, once taken
  bool have_provenance_{false};
  Fields extra_;
  std::string series_;
  std::atomic<int64_t> errors_{0};
};

}  // namespace rocklab::record
