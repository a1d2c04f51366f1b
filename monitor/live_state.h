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
/// Memory bound (finite window): every series (the measured theta, each
/// variant's theta, each variant's comparison) holds at most
/// SeriesCapacity() = ceil(window_s * series_rate_hz) + 2 points; at most
/// max_events events, max_intervals flag intervals, max_variants variants,
/// max_nodes health entries and max_channels per-channel counters. What does
/// not fit is counted (counters.dropped), never silently lost. With
/// window_s = infinity the series grow with the record (the report's use)
/// up to max_points when it is set: a series that reaches it halves its
/// resolution (keeps the first point of every two slots and doubles its slot
/// from then on), so a series of any length holds between max_points / 2 and
/// max_points points; the events and flag intervals rings grow (doubling) up
/// to max_events and max_intervals.
///
/// ## Snapshot / UpdateSince JSON schema (`"schema": "rocklab.monitor.v1"`)
/// Times `t` are sample-clock seconds relative to `t0_utime` (the first
/// sample of the record); angles of the series are in DEGREES (display);
/// the latest comparison numbers are exactly as received (SI: rad, s, 1).
/// NaN and infinities are written as null.
/// ```
/// {
///   "schema": "rocklab.monitor.v1",
///   "full": true,          // true: replaces everything the reader holds;
///                          // false: points/events/flags after the reader's cursor
///   "cursor": 1234,        // pass to UpdateSince() to get what comes after
///   "record": 1,           // a record starts when the sample clock goes back
///   "t0_utime": 1000000,   // sample clock of t = 0, us (null before any sample)
///   "t_latest": 6.99,      // newest sample-clock time of the series, s (null: none)
///   "window_s": 60,        // null: the whole record
///   "series_rate_hz": 100, // at most this many points per second per series
///   "max_points": 20000,   // points per series at most (null: no cap; a capped
///                          // series is coarser than series_rate_hz)
///   "from_s": 0, "to_s": null,  // the time window kept (null: no end)
///   "measured": {"t": [..], "theta_deg": [..]},             // RL_THETA theta
///   "table": {"t": [..], "accel_mps2": [..],                 // RL_TABLE u_g'' (m/s^2)
///             "samples": 7000, "peak_accel_mps2": 2.6, "peak_disp_m": 0.006},
///                          // samples and peaks: every RL_TABLE in from_s..to_s
///   "variants": [          // in order of appearance
///     {"name": "fitted_complex",
///      "model": "complex", "alpha": 0.235, "p": 3.884, "mu": 0.937, "l": 0,
///      "equations": "eq10",  // "housner", "eq10" or "limit": which equations produced
///                          // the newest sample; null from an older log's model_state_t
///                          // from RL_MODEL_<name> (rad, rad/s, 1, 1); null until seen
///      "theta": {"t": [..], "theta_deg": [..]},              // RL_MODEL_<name>
///      "comparison": {"t": [..], "error_deg": [..], "rms_window_deg": [..]},
///      "latest": {         // the newest RL_COMPARE_<name>, exactly as received
///        "utime": .., "t": .., "error": .., "rms_window": .., "window_s": ..,
///        "rms_total": .., "nrms": .., "peak_error": .., "impact_timing_error": ..,
///        "correlation": .., "valid": true, "samples": 6996} or null}],
///   "flags": [             // sliding, jump, twist (RL_THETA flags), stale (RL_EVENT)
///     {"id": 7, "flag": "sliding", "source": "daq", "start": 1.2, "end": 1.5}],
///                          // "end": null while the flag is still raised
///   "events": [
///     {"t": 1.0, "utime": .., "source": "fitted_complex", "kind": "impact",
///      "code": 2, "value": -0.31, "detail": "impact"}],
///   "health": [            // latest RL_HEALTH per node
///     {"node": "daq", "state": "running", "utime": .., "rate_in_hz": .., "rate_out_hz": ..,
///      "count_in": .., "count_out": .., "dropped": .., "gaps": .., "bad_samples": ..,
///      "lag_s": ..}],
///   "config": {"rig_name": .., "calibration_id": .., "sample_rate_hz": ..,
///              "alpha": .., "p": .., "mu": ..} or null,           // RL_DAQ_CONFIG
///   "counters": {"messages": {"RL_THETA": 6996, ..},  // every ingested message
///                "decode_errors": {"RL_THETA": 0, ..},
///                "seq_gaps": {"RL_THETA": 0, ..},     // channels whose type has a seq:
///                "seq_missing": {"RL_THETA": 0, ..},  // forward jumps, messages they skip
///                                     // (RL_EVENT, RL_HEALTH: per sender, summed)
///                "dropped": {"out_of_order": .., "events": .., "intervals": ..,
///                            "variants": .., "nodes": .., "channels": ..,
///                            "far_from_clock": ..},  // wild sample clocks
///                "outside_window": ..},  // points and events left out by from_s..to_s
///   "units": {..}          // unit of every quantity above
/// }
/// ```
/// A full answer holds what lies in the window (points, events and flags that
/// end at or after t_latest - window_s); an update holds only the points and
/// events added after the cursor and the flags opened or closed after it,
/// with the variants' metadata, health, config and counters in full.
/// A reader whose cursor is from an earlier record gets a full answer.

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

  /// Everything held, as one JSON object (schema above); same as UpdateSince(0).
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
