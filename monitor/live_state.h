#pragma once
/// @file
/// What the live monitor shows, held in memory: the RL_ channels decoded into
/// decimated time series, flag intervals, events, health, the rig and the
/// model parameters. `rocklab monitor` feeds it from LCM and serves it to the
/// page; `rocklab report` feeds it from a log (window_s = infinity) and
/// inlines its Snapshot() into a static page.
///
/// Threading: Ingest (the LCM thread) and Snapshot/UpdateSince (the HTTP
/// threads) may run concurrently; one mutex guards the state. Ingest does not
/// allocate once the series rings are full (a bounded window), except for the
/// first message of a new channel, variant or node and for text fields longer
/// than any seen before.
///
/// Memory is bounded by LiveOptions (what does not fit is counted in
/// counters.dropped); the bound and the JSON schema of Snapshot() and
/// UpdateSince() ("rocklab.monitor.v1") are in docs/monitor.md.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <mutex>
#include <string>

#include <nlohmann/json.hpp>

namespace rocklab::monitor {

struct LiveOptions {
  /// Sample-clock seconds kept; infinity keeps the whole record (still
  /// decimated to series_rate_hz). > 0.
  double window_s{60.0};
  /// Points per second kept per series (decimation on the sample clock), Hz; > 0.
  double series_rate_hz{100.0};
  std::size_t max_events{1000};     ///< events kept, newest; >= 1
  std::size_t max_intervals{1000};  ///< flag intervals kept, newest; >= 1
  std::size_t max_variants{32};     ///< model variants tracked; >= 1
  std::size_t max_nodes{32};        ///< nodes whose health is kept; >= 1
  std::size_t max_channels{256};    ///< channels with their own counters; >= 1
  /// Points per series at most with an infinite window (0: no cap; else >= 16).
  std::size_t max_points{0};
  /// Time window, sample-clock s after the record's first sample (t = 0):
  /// series points and events outside [from_s, to_s] are left out (counted
  /// as outside_window), flag intervals are cut to it. 0 <= from_s < to_s.
  double from_s{0.0};
  double to_s{std::numeric_limits<double>::infinity()};
  std::string channel_prefix{"RL_"};
  /// A sample clock going back by more than this (a replay restarted, a new
  /// test) starts a new record: the series, flags and events are cleared, s; > 0.
  /// A sample this far from the clock either way is held, not shown, until
  /// 5 agreeing samples (or one after an RL_DAQ_CONFIG on their clock) show
  /// the clock really jumped; a lone wild one is dropped, counted
  /// (counters.dropped.far_from_clock). Events never move the clock.
  double new_record_after_s{1.0};
  /// @throws std::invalid_argument naming the option.
  void Validate() const;
};

class LiveState {
 public:
  /// @throws std::invalid_argument for invalid options.
  explicit LiveState(const LiveOptions& options = {});
  ~LiveState();
  LiveState(const LiveState&) = delete;
  LiveState& operator=(const LiveState&) = delete;

  /// Decodes one LCM message by its channel name: <prefix>THETA
  /// (block_state_t), <prefix>TABLE (table_state_t), <prefix>MODEL_<name> (model_state3_t, or
  /// model_state2_t, model_state_t), <prefix>COMPARE_<name> (comparison2_t or comparison_t),
  /// <prefix>EVENT (event2_t or event_t), <prefix>HEALTH (health2_t or health_t),
  /// <prefix>DAQ_CONFIG (daq_config2_t or daq_config_t). The older types come from logs
  /// written before the current ones; they carry no seq.
  /// Every message is counted under its channel; one that fails to decode is
  /// counted as a decode error of its channel. Never throws.
  /// @return true when the channel is one of the above and the payload decoded.
  bool Ingest(const std::string& channel, const void* data, int size);

  /// Everything held, as one JSON object (docs/monitor.md); same as UpdateSince(0).
  nlohmann::json Snapshot() const;
  /// What changed after `cursor` (a "cursor" of an earlier answer; 0: all).
  nlohmann::json UpdateSince(std::uint64_t cursor) const;
  /// The cursor an UpdateSince(cursor()) would return: changes when anything
  /// is ingested. Cheap; lets a pusher skip a quiet period.
  std::uint64_t cursor() const;

  /// Points each series holds at most (finite window); 0 with an infinite window.
  std::size_t SeriesCapacity() const;
  const LiveOptions& options() const { return options_; }

 private:
  struct Impl;
  LiveOptions options_;
  mutable std::mutex mutex_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rocklab::monitor
