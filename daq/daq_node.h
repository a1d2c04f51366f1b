#pragma once
/// @file
/// The DAQ node: reads one source on its sample clock and publishes
/// RL_DAQ_CONFIG, RL_RAW, RL_TABLE, RL_THETA, RL_EVENT and RL_HEALTH.
///
/// Threading model: one thread, the caller's. Run() loops read -> pace ->
/// process -> publish; nothing is queued between threads, so nothing can be
/// dropped inside the node, and memory is bounded by the differentiators'
/// windows. Signal handlers (in the command) only set the `stop` flag, which
/// Run() polls before every frame and while pacing (every 20 ms at most).
/// Shutdown order: stop reading; flush the delayed RL_THETA / RL_TABLE
/// samples of what was read; publish a last RL_HEALTH with state "stopped";
/// return. LCM handles are never dispatched here (the node only publishes).
/// When paced, a burst of more than 16 messages between two frames (the
/// differentiators' flush at the end or after a long gap) is spread at 1 ms
/// per 16 messages, below LCM's default subscriber queue of 30.

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "daq/rig_config.h"
#include "rocklab/block_state_t.hpp"
#include "rocklab/table_state_t.hpp"

namespace lcm {
class LCM;
}

namespace rocklab::daq {

struct DaqNodeConfig {
  RigConfig rig;
  std::string input;             ///< CSV, LVM or LCM log
  double speed{1.0};             ///< sample-clock s per host s; 0 = as fast as possible
  std::string lcm_url;           ///< empty: LCM's default (LCM_DEFAULT_URL or its built-in)
  std::string prefix{"RL_"};     ///< channel names are prefix + DAQ_CONFIG, RAW, ...
  double config_period_s{5.0};   ///< RL_DAQ_CONFIG repeat, sample-clock s
  double health_period_s{1.0};   ///< RL_HEALTH period, host s
  /// Optional observers, called synchronously in Run()'s thread with exactly
  /// the RL_TABLE / RL_THETA message just published (same values, same
  /// order), so a caller can connect later stages by direct calls. They must
  /// not throw (an exception is caught, logged and counted as a problem).
  std::function<void(const rocklab::table_state_t&)> on_table;
  std::function<void(const rocklab::block_state_t&)> on_theta;
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
  bool stopped_early{};      ///< stop was requested before the end of the input
};

class DaqNode {
 public:
  /// Opens the source and binds the rig's channels to it.
  /// @param lcm non-owning, may be null: the node then creates its own LCM
  ///        instance on config.lcm_url. Must outlive the node.
  /// @throws std::runtime_error / std::invalid_argument on a bad input file,
  ///         a rig channel the input lacks, or an LCM URL that does not open.
  explicit DaqNode(DaqNodeConfig config, lcm::LCM* lcm = nullptr);
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
