#pragma once
/// @file
/// The DAQ node: reads one source on its sample clock and publishes
/// RL_DAQ_CONFIG, RL_RAW, RL_TABLE, RL_THETA, RL_EVENT and RL_HEALTH; with
/// a multi-body rig also RL_BODIES (block_state2_t, every body) right after
/// each RL_THETA (the bottom body's block_state_t).
///
/// Threading model: one thread, the caller's. Run() loops read -> pace ->
/// process -> publish; nothing is queued between threads, so nothing can be
/// dropped inside the node, and memory is bounded by the differentiators'
/// windows. Signal handlers (in the command) only set the `stop` flag, which
/// Run() polls before every frame and while pacing (every 20 ms at most).
/// Shutdown order: stop reading; flush the delayed RL_THETA / RL_TABLE
/// samples of what was read; publish a last RL_HEALTH with state "stopped";
/// return. The bus is never handled here (the node only publishes; on a
/// DirectBus its Publish drives the subscribed stages of `rocklab run`).
/// RL_THETA and RL_TABLE of a sample go out together, RL_THETA first (the
/// Processor pairs them), so no subscriber has to align them.
/// Live inputs (tcp://, lcm://, --follow) are not paced: each frame goes out
/// as it arrives; while none arrives Run wakes every 0.1 s for RL_HEALTH
/// (and the systemd watchdog, common/sd_notify.h). While a text input waits
/// for its header (in the constructor, or after a restart) the source calls
/// back every 0.1 s: READY=1 once (the input is open), then RL_HEALTH
/// "waiting for header" (utime 0: no sample yet) and WATCHDOG=1.
/// When paced (or live), a burst of more than 16 messages between two frames (the
/// differentiators' flush at the end or after a long gap) is spread at 1 ms
/// per 16 messages, below LCM's default subscriber queue of 30.

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>

#include "daq/rig_config.h"

namespace rocklab::common {
class Bus;
}

namespace rocklab::daq {

struct DaqNodeConfig {
  RigConfig rig;
  std::string input;             ///< CSV, LVM, LCM log, tcp://HOST:PORT or lcm://CHANNEL
  char delimiter{0};             ///< CSV field separator (',', ';', tab); 0 = sniffed
  bool follow{false};            ///< CSV/LVM: keep reading as the file grows
  double idle_timeout_s{0};      ///< live inputs end after this long without data, s; 0 = never
  std::string lcm_url;           ///< lcm:// inputs: where the acquisition program publishes
  /// Live inputs: waiting for their header ends when *stop is true.
  /// Non-owning, may be null; must outlive the node (Run's `stop`).
  const std::atomic<bool>* stop{};
  double speed{1.0};             ///< sample-clock s per host s; 0 = as fast as possible
  std::string prefix{"RL_"};     ///< channel names are prefix + DAQ_CONFIG, RAW, ...
  double config_period_s{5.0};   ///< RL_DAQ_CONFIG repeat, sample-clock s
  double health_period_s{1.0};   ///< RL_HEALTH period, host s
  /// @throws std::invalid_argument naming the field.
  void Validate() const;
};

/// Counters of one run (also in the last RL_HEALTH).
struct DaqNodeStats {
  int64_t frames_read{};     ///< frames from the source
  int64_t published{};       ///< LCM messages published
  int64_t publish_errors{};  ///< publish calls that failed
  int64_t gaps{};            ///< sequence gaps
  int64_t missing{};         ///< samples lost in gaps
  int64_t bad_samples{};     ///< bad rows + bad values + duplicate / out-of-order frames
  int64_t problems{};        ///< problems reported (each logged, at most one line a second)
  int64_t damaged_regions{}; ///< LCM log input: damaged regions skipped (each also a problem)
  int64_t damaged_bytes{};   ///< LCM log input: bytes in them
  int64_t damaged_events{};  ///< LCM log input: events lost in them
  int64_t restarts{};        ///< live inputs: reconnections, files replaced
  int64_t restart_lost{};    ///< live inputs: samples lost across restarts (from the time column)
  int64_t comments{};        ///< LVM Comment texts sent as RL_EVENT COMMENT
  bool stopped_early{};      ///< stop was requested before the end of the input
  /// The input could not be read to its end (Source::error(), naming the
  /// file); empty otherwise. Run still shut down in order (RL_HEALTH "stopped").
  std::string read_error;
};

class DaqNode {
 public:
  /// Opens the source and binds the rig's channels to it.
  /// @param bus where every message goes; not owned, must outlive the node.
  /// @throws std::runtime_error / std::invalid_argument on a bad input file
  ///         or a rig channel the input lacks.
  DaqNode(DaqNodeConfig config, common::Bus& bus);
  ~DaqNode();
  DaqNode(const DaqNode&) = delete;
  DaqNode& operator=(const DaqNode&) = delete;

  /// Reads the input to its end or until `stop` is true. Never throws on the
  /// streaming path (problems are logged, counted and sent as events).
  void Run(const std::atomic<bool>& stop);

  const DaqNodeStats& stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rocklab::daq
