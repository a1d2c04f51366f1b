#pragma once
// Private to monitor/live_state*.cpp: LiveState's state (LiveState::Impl) and
// the helpers its three parts share. The parts: live_state.cpp (options,
// the public calls and their lock), live_ingest.cpp (a message into the
// state), live_json.cpp (the state as the page's JSON).

#include "monitor/live_state.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "common/ring.h"
#include "common/text.h"
#include "common/units.h"
#include "common/wire.h"
#include "rocklab/band_comparison_t.hpp"
#include "rocklab/block_state2_t.hpp"
#include "rocklab/block_state_t.hpp"
#include "rocklab/comparison3_t.hpp"
#include "common/versions.h"
#include "rocklab/model_band_t.hpp"
#include "rocklab/table_state_t.hpp"

namespace rocklab::monitor {
namespace live_detail {


using nlohmann::json;
using common::Ring;
using common::kDegPerRad;
constexpr std::size_t kGrowingInitialCapacity = 4096;
constexpr std::size_t kMaxTextBytes = 256;  // event details and names are cut here

using common::StartsWith;

// The block-state flags the page shows as bands, in this order.
struct FlagBit {
  std::int32_t bit;
  const char* name;
};
constexpr std::array<FlagBit, 3> kFlagBits{{{rocklab::block_state_t::FLAG_SLIDING, "sliding"},
                                            {rocklab::block_state_t::FLAG_JUMP, "jump"},
                                            {rocklab::block_state_t::FLAG_TWIST, "twist"}}};
constexpr std::int8_t kStaleFlag = static_cast<std::int8_t>(kFlagBits.size());  // index past the bits

inline const char* FlagName(std::int8_t flag) {
  return flag == kStaleFlag ? "stale" : kFlagBits[static_cast<std::size_t>(flag)].name;
}

inline const char* EventKindName(std::int8_t kind) {
  switch (kind) {
    case rocklab::event_t::UPLIFT: return "uplift";
    case rocklab::event_t::IMPACT: return "impact";
    case rocklab::event_t::REST: return "rest";
    case rocklab::event_t::OVERTURN: return "overturn";
    case rocklab::event_t::SLIDING: return "sliding";
    case rocklab::event_t::TWIST: return "twist";
    case rocklab::event_t::GAP: return "gap";
    case rocklab::event_t::STALE: return "stale";
    case rocklab::event_t::JUMP: return "jump";
    case rocklab::event_t::OUT_OF_PLANE: return "out_of_plane";
    case rocklab::event_t::DISAGREE: return "disagree";
    case rocklab::event_t::RECOVERED: return "recovered";
    case rocklab::event_t::BAD_SAMPLE: return "bad_sample";
    default: return "unknown";
  }
}

// model_state2_t's EQUATIONS_ code as the monitor's JSON names it; nullptr
// (JSON null) when unknown (a model_state_t from an older log).
inline const char* EquationsName(std::int8_t code) {
  switch (code) {
    case rocklab::model_state3_t::EQUATIONS_HOUSNER: return "housner";
    case rocklab::model_state3_t::EQUATIONS_EQ10: return "eq10";
    case rocklab::model_state3_t::EQUATIONS_LIMIT: return "limit";
    default: return nullptr;
  }
}

// Assigns at most kMaxTextBytes: a text field of a message cannot grow the state.
inline void AssignText(std::string& to, const std::string& from) {
  to.assign(from, 0, std::min(from.size(), kMaxTextBytes));
}

// One point of a series: two values at one sample-clock time.
struct Point {
  std::uint64_t seq{};   // LiveState change number when stored
  std::int64_t utime{};  // sample clock, us
  double a{};
  double b{};
};

// A decimated time series in a ring: at most one point per slot of the
// sample clock (the first sample of the slot; a slot is 1/rate, times
// `coarsening`). A growing series (the whole record) doubles its ring when
// full; at `max_points` (0: no cap) it halves its resolution instead.
class Series {
 public:
  Series(std::size_t capacity, bool grows, std::size_t max_points = 0)
      : ring_(max_points > 0 ? std::min(capacity, max_points) : capacity),
        grows_(grows),
        max_points_(max_points) {}

  enum class Outcome { kStored, kDecimated, kOutOfOrder };
  Outcome Add(std::uint64_t seq, std::int64_t utime, std::int64_t t0, double period_us, double a,
              double b) {
    if (!ring_.empty() && utime <= ring_.back().utime) return Outcome::kOutOfOrder;
    std::int64_t slot = Slot(utime, t0, period_us);
    if (!ring_.empty() && slot <= last_slot_) return Outcome::kDecimated;
    if (grows_ && ring_.full()) {
      if (max_points_ == 0 || ring_.capacity() < max_points_) {
        Grow();
      } else {
        Coarsen(t0, period_us);
        slot = Slot(utime, t0, period_us);
        if (slot <= last_slot_) return Outcome::kDecimated;
      }
    }
    ring_.push_back(Point{seq, utime, a, b});
    last_slot_ = slot;
    return Outcome::kStored;
  }

  void Clear() {
    while (!ring_.empty()) ring_.pop_front();
    coarsening_ = 1;
  }

  std::size_t size() const { return ring_.size(); }
  const Point& operator[](std::size_t i) const { return ring_[i]; }

  // Index of the first point to output: the first after `cursor` (an
  // update), or the first at or after `from_utime` (a full answer).
  std::size_t FirstAfter(std::uint64_t cursor) const {
    std::size_t i = ring_.size();
    while (i > 0 && ring_[i - 1].seq > cursor) --i;
    return i;
  }
  std::size_t FirstFrom(std::int64_t from_utime) const {
    std::size_t lo = 0, hi = ring_.size();
    while (lo < hi) {
      const std::size_t mid = (lo + hi) / 2;
      if (ring_[mid].utime < from_utime) {
        lo = mid + 1;
      } else {
        hi = mid;
      }
    }
    return lo;
  }

 private:
  std::int64_t Slot(std::int64_t utime, std::int64_t t0, double period_us) const {
    return static_cast<std::int64_t>(
        std::floor(static_cast<double>(utime - t0) / (period_us * static_cast<double>(coarsening_))));
  }

  void Grow() {
    std::size_t capacity = ring_.capacity() * 2;
    if (max_points_ > 0) capacity = std::min(capacity, max_points_);
    Ring<Point> bigger(capacity);
    for (std::size_t i = 0; i < ring_.size(); ++i) bigger.push_back(ring_[i]);
    ring_ = std::move(bigger);
  }

  // Doubles the slot and keeps the first point of each new slot: at most one
  // point per old slot means at most two per new slot, so about half remain.
  // One allocation per halving (log2 of the record's length in all).
  void Coarsen(std::int64_t t0, double period_us) {
    coarsening_ *= 2;
    Ring<Point> kept(ring_.capacity());
    std::int64_t last = 0;
    for (std::size_t i = 0; i < ring_.size(); ++i) {
      const std::int64_t slot = Slot(ring_[i].utime, t0, period_us);
      if (!kept.empty() && slot <= last) continue;
      kept.push_back(ring_[i]);
      last = slot;
    }
    ring_ = std::move(kept);
    last_slot_ = last;
  }

  Ring<Point> ring_;
  bool grows_;
  std::size_t max_points_;
  std::int64_t coarsening_{1};  // slot = coarsening_ / rate
  std::int64_t last_slot_{};
};

// A ring that doubles up to `max` items when `grows` (the report's whole
// record), else a fixed ring of `max` items (the monitor's window).
template <class T>
void PushGrowing(Ring<T>& ring, const T& item, bool grows, std::size_t max, std::int64_t& dropped) {
  if (grows && ring.full() && ring.capacity() < max) {
    Ring<T> bigger(std::min(max, ring.capacity() * 2));
    for (std::size_t i = 0; i < ring.size(); ++i) bigger.push_back(ring[i]);
    ring = std::move(bigger);
  }
  if (!ring.push_back(item)) ++dropped;
}

struct Interval {
  std::uint64_t id{};
  std::uint64_t seq{};  // change number of its opening or closing
  std::int8_t flag{};   // index in kFlagBits, or kStaleFlag
  std::string source;
  std::int64_t start{}, end{};  // sample clock, us
  bool open{};
};

struct Event {
  std::uint64_t seq{};
  std::int64_t utime{};
  std::string source;
  std::int8_t kind{};
  double value{};
  std::string detail;
};

struct ChannelCount {
  std::int64_t messages{};
  std::int64_t decode_errors{};
  common::ChannelSeqGaps seq;  // the publishers' sequence numbers (per sender)
};

}  // namespace live_detail

struct LiveState::Impl {
  // The helper types by their short names (each .cpp of the state names
  // the rest of live_detail itself).
  using Series = live_detail::Series;
  using Interval = live_detail::Interval;
  using Event = live_detail::Event;
  using ChannelCount = live_detail::ChannelCount;
  using json = nlohmann::json;
  template <class T>
  using Ring = common::Ring<T>;

  struct Variant {
    Variant(std::string_view n, std::size_t capacity, bool grows, std::size_t max_points)
        : name(n), theta(capacity, grows, max_points), comparison(capacity, grows, max_points) {}
    std::string name;
    bool has_params{};
    rocklab::model_state3_t params;  // the newest RL_MODEL_<name>: model, alpha, p, mu, l, equations
    Series theta;       // a: theta, deg
    Series comparison;  // a: error, deg; b: rms_window, deg
    bool has_latest{};
    rocklab::comparison2_t latest;
    // An assembly (model_state4_t of two or more bodies): theta per body,
    // bottom-up (a: theta, deg), and the newest RL_COMPAREBODIES_<name>.
    std::vector<std::unique_ptr<Series>> bodies;
    bool has_bodies_latest{};
    rocklab::comparison3_t bodies_latest;
    // Whole-test figures over the window, at the model's full rate (not the
    // decimated series): max |theta| of RL_MODEL_<name>, rad; the impact
    // timing errors of RL_COMPARE_<name>, one per matched crossing (a new
    // crossing changes the carried value), their sum of squares, s^2.
    double peak_abs_theta{};
    std::int64_t timing_count{};
    double timing_sum_sq{};
    double timing_last{std::numeric_limits<double>::quiet_NaN()};
  };

  // An ensemble's posterior predictive band (RL_BAND_<name>) and its
  // comparison with the measurement (RL_COVERAGE_<name>). The three series
  // take the same samples, so their points line up index by index.
  struct Band {
    Band(std::string_view n, std::size_t capacity, bool grows, std::size_t max_points)
        : name(n), median(capacity, grows, max_points), band68(capacity, grows, max_points),
          band95(capacity, grows, max_points) {}
    std::string name;
    bool has_params{};
    std::string model;
    std::int32_t draws{}, members{};
    Series median;  // a: median theta, deg
    Series band68;  // a: 16 %, b: 84 % quantile of theta, deg
    Series band95;  // a: 2.5 %, b: 97.5 %, deg
    bool has_latest{};
    rocklab::band_comparison_t latest;
  };

  explicit Impl(const LiveOptions& o)
      : options(o),
        grows(!std::isfinite(o.window_s)),
        capacity(grows ? live_detail::kGrowingInitialCapacity
                       : static_cast<std::size_t>(std::ceil(o.window_s * o.series_rate_hz)) + 2),
        period_us(1e6 / o.series_rate_hz),
        measured(capacity, grows, o.max_points),
        table(capacity, grows, o.max_points),
        intervals(grows ? std::min<std::size_t>(o.max_intervals, 1024) : o.max_intervals),
        events(grows ? std::min<std::size_t>(o.max_events, 1024) : o.max_events) {}

  // -- ingestion ------------------------------------------------------------

  bool Ingest(std::string_view channel, const void* data, int size);
  // The message to its Ingest* by channel kind; `known` false for another.
  bool Dispatch(std::string_view kind, const void* data, int size, bool& known);
  // The held samples' clock is real: a new record (or the clock followed),
  // then the held samples ingested.
  void AcceptClockJump();
  bool IngestTheta(const void* data, int size);
  bool IngestTable(const void* data, int size);
  bool IngestModel(std::string_view name, const void* data, int size);
  bool IngestCompare(std::string_view name, const void* data, int size);
  bool IngestBodies(const void* data, int size);
  bool IngestCompareBodies(std::string_view name, const void* data, int size);
  // Series k of `list`, made (empty) up to k; nullptr beyond kMaxBodies
  // (counted in dropped.bodies).
  Series* BodySeries(std::vector<std::unique_ptr<Series>>& list, std::size_t k);
  bool IngestBand(std::string_view name, const void* data, int size);
  bool IngestCoverage(std::string_view name, const void* data, int size);
  bool IngestEvent(const void* data, int size);
  bool IngestHealth(const void* data, int size);
  bool IngestConfig(const void* data, int size);

  ChannelCount* CountFor(std::string_view channel) {
    auto it = channels.find(channel);
    if (it != channels.end()) return &it->second;
    if (channels.size() >= options.max_channels) {
      ++dropped_channels;
      return nullptr;
    }
    return &channels.emplace(std::string(channel), ChannelCount{}).first->second;
  }

  Variant* VariantFor(std::string_view name) {
    auto it = by_name.find(name);
    if (it != by_name.end()) return it->second;
    if (variants.size() >= options.max_variants) {
      ++dropped_variants;
      return nullptr;
    }
    variants.push_back(std::make_unique<Variant>(name, capacity, grows, options.max_points));
    by_name.emplace(std::string(name), variants.back().get());
    return variants.back().get();
  }

  Band* BandFor(std::string_view name) {
    auto it = band_by_name.find(name);
    if (it != band_by_name.end()) return it->second;
    if (bands.size() >= options.max_variants) {  // bands count against the variants' bound
      ++dropped_variants;
      return nullptr;
    }
    bands.push_back(std::make_unique<Band>(name, capacity, grows, options.max_points));
    band_by_name.emplace(std::string(name), bands.back().get());
    return bands.back().get();
  }

  // A time from the wire may become the origin: beyond +-2^53 us (285 years)
  // it is corrupt, and differences of such times overflow int64. Refused as a
  // decode error (counted per channel).
  static bool UsableUtime(std::int64_t utime) {
    constexpr std::int64_t kMaxAbsUtime = std::int64_t{1} << 53;
    return utime >= -kMaxAbsUtime && utime <= kMaxAbsUtime;
  }

  // A sample-clock reading of a series: sets t0, and says whether the
  // sample may be used. A sample farther than new_record_after_s from the
  // clock (either way) is held, not used: one wild datagram must not start
  // a new record or move the origin. kAgreeingSamples far samples that agree
  // with each other (or one after an RL_DAQ_CONFIG that announced the new
  // clock) are a real jump: Ingest then starts a new record (the clock went
  // back, a configuration announced a new test, or the old clock was never
  // confirmed) or follows it (a forward gap), and ingests the held samples. Far samples a near one interrupts
  // were wild: dropped, counted (counters.dropped.far_from_clock).
  bool SeeSampleClock(std::int64_t utime) {
    if (!has_clock) {
      has_clock = true;
      t0_utime = latest_utime = utime;
      samples_on_clock = 1;
      return true;
    }
    const double far_us = options.new_record_after_s * 1e6;
    if (std::fabs(static_cast<double>(utime) - static_cast<double>(latest_utime)) <= far_us) {
      DropCandidate();
      latest_utime = std::max(latest_utime, utime);
      ++samples_on_clock;
      return true;
    }
    if (candidate_count == 0 ||
        std::fabs(static_cast<double>(utime) - static_cast<double>(candidate_latest)) > far_us) {
      DropCandidate();
      candidate_first = candidate_latest = utime;
    }
    candidate_latest = std::max(candidate_latest, utime);
    ++candidate_count;
    hold_current = true;
    if (candidate_count >= kAgreeingSamples) jump_ready = true;
    return false;
  }

  // Far samples held that turned out wild: counted, forgotten.
  void DropCandidate() {
    dropped_far_from_clock += static_cast<std::int64_t>(held.size());
    held.clear();
    candidate_count = 0;
    candidate_new_test = false;
  }

  // Decodes a message of a series into `msg` (guarded: common::GuardedDecode
  // checks lengths before decode allocates) with a usable utime.
  template <class Msg>
  bool DecodeSample(Msg& msg, const void* data, int size) {
    return common::GuardedDecode(data, size, msg) == nullptr && UsableUtime(msg.utime);
  }

  void NewRecord() {
    ++record;
    record_start_seq = seq;  // the change being ingested belongs to the new record
    has_clock = false;
    measured.Clear();
    measured_bodies.clear();
    table.Clear();
    table_samples = 0;
    table_peak_accel = table_peak_disp = 0.0;
    measured_peak_abs_theta = 0.0;
    variants.clear();
    by_name.clear();
    bands.clear();
    band_by_name.clear();
    while (!intervals.empty()) intervals.pop_front();
    while (!events.empty()) events.pop_front();
    open_flags.fill(0);
    open_stale.clear();
    samples_on_clock = 0;
  }

  // Inside the time window from_s..to_s (s after t0)?
  bool InWindow(std::int64_t utime) const {
    const double t = T(utime);
    return t >= options.from_s && t <= options.to_s;
  }

  void AddPoint(Series& s, std::int64_t utime, double a, double b) {
    if (!InWindow(utime)) {
      ++outside_window;
      return;
    }
    if (s.Add(seq, utime, t0_utime, period_us, a, b) == Series::Outcome::kOutOfOrder) {
      ++dropped_out_of_order;
    }
  }

  std::uint64_t OpenInterval(std::int8_t flag, const std::string& source, std::int64_t utime) {
    Interval& iv = interval_scratch;
    iv.id = ++last_interval_id;
    iv.seq = seq;
    iv.flag = flag;
    live_detail::AssignText(iv.source, source);
    iv.start = iv.end = utime;
    iv.open = true;
    live_detail::PushGrowing(intervals, iv, grows, options.max_intervals, dropped_intervals);
    return iv.id;
  }

  void CloseInterval(std::uint64_t id, std::int64_t utime) {
    for (std::size_t i = intervals.size(); i > 0; --i) {
      Interval& iv = intervals[i - 1];
      if (iv.id == id) {
        iv.open = false;
        iv.end = utime;
        iv.seq = seq;
        return;
      }
    }  // pushed out of the ring while open: nothing to close
  }

  // -- output -----------------------------------------------------------------

  json Update(std::uint64_t cursor) const;
  // The parts of Update (live_json.cpp): what one update carries.
  struct UpdateWindow {
    bool full{};              // a full snapshot (else what changed after `cursor`)
    std::uint64_t cursor{};   // the page's cursor (seq)
    std::int64_t from_utime{};  // full: the window's start, us
  };
  json SeriesJson(const Series& s, const char* a_name, const char* b_name, const UpdateWindow& w) const;
  json VariantsJson(const UpdateWindow& w) const;
  json BandsJson(const UpdateWindow& w) const;
  json FlagsJson(const UpdateWindow& w) const;
  json EventsJson(const UpdateWindow& w) const;
  json HealthJson() const;
  json CountersJson() const;
  static json UnitsJson();
  double T(std::int64_t utime) const { return static_cast<double>(utime - t0_utime) * 1e-6; }

  const LiveOptions options;
  const bool grows;
  const std::size_t capacity;
  const double period_us;

  std::uint64_t seq{};  // change number: one per ingested message
  std::uint64_t record{1};
  std::uint64_t record_start_seq{};
  bool has_clock{};
  std::int64_t t0_utime{}, latest_utime{};

  // The clock guard (SeeSampleClock): far samples held until they agree.
  static constexpr int kAgreeingSamples = 5;
  struct Held {
    std::string channel;
    std::vector<std::uint8_t> bytes;
  };
  std::vector<Held> held;             // at most kAgreeingSamples
  int candidate_count{};              // far samples agreeing with each other (0: none)
  std::int64_t candidate_first{}, candidate_latest{};  // their sample clock, us
  std::int64_t samples_on_clock{};    // samples used since the clock was set
  bool candidate_new_test{};          // announced by an RL_DAQ_CONFIG on its clock
  bool hold_current{}, jump_ready{};  // set for Ingest by SeeSampleClock
  std::int64_t dropped_far_from_clock{};

  Series measured;  // a: theta, deg
  double measured_peak_abs_theta{};  // max |theta| of RL_THETA in the window, every sample, rad
  Series table;     // a: u_g'', m/s^2; b: u_g, m
  std::int64_t table_samples{};  // RL_TABLE in the time window
  double table_peak_accel{}, table_peak_disp{};  // max |u_g''| (m/s^2), |u_g| (m) in it
  std::int64_t outside_window{};  // points and events left out by from_s..to_s
  std::vector<std::unique_ptr<Variant>> variants;  // in order of appearance
  std::map<std::string, Variant*, std::less<>> by_name;
  std::vector<std::unique_ptr<Band>> bands;  // in order of appearance
  std::map<std::string, Band*, std::less<>> band_by_name;

  Ring<Interval> intervals;
  Interval interval_scratch;
  std::uint64_t last_interval_id{};
  std::array<std::uint64_t, live_detail::kFlagBits.size()> open_flags{};  // interval id, 0: none
  std::map<std::string, std::uint64_t, std::less<>> open_stale;  // source -> interval id

  Ring<Event> events;
  Event event_scratch;
  std::map<std::string, rocklab::health2_t, std::less<>> health;  // by node

  bool has_config{};
  std::string rig_name, calibration_id;
  double sample_rate_hz{}, alpha{}, p{}, mu{};

  std::map<std::string, ChannelCount, std::less<>> channels;
  std::int64_t dropped_out_of_order{}, dropped_intervals{}, dropped_events{},
      dropped_variants{}, dropped_nodes{}, dropped_channels{};
  // An assembly's measured theta per body (RL_BODIES), bottom-up (a: deg).
  // At most kMaxBodies bodies are drawn; the others counted here.
  static constexpr std::size_t kMaxBodies = 16;
  std::vector<std::unique_ptr<Series>> measured_bodies;
  std::int64_t dropped_bodies{};

  // Decoding buffers, reused: strings keep their capacity.
  rocklab::block_state_t theta_msg;
  rocklab::table_state_t table_msg;
  // The older types (logs written before) are read as the current ones.
  rocklab::model_state3_t model_msg;  // body 0 of model4_msg
  rocklab::model_state4_t model4_msg;
  common::ModelStateBodiesDecoder model_decoder;
  rocklab::block_state2_t bodies_msg;
  rocklab::comparison3_t compare_bodies_msg;
  rocklab::model_band_t band_msg;
  rocklab::band_comparison_t coverage_msg;
  rocklab::comparison2_t compare_msg;
  common::ComparisonDecoder compare_decoder;
  rocklab::event2_t event_msg;
  common::EventDecoder event_decoder;
  rocklab::health2_t health_msg;
  common::HealthDecoder health_decoder;
  rocklab::daq_config2_t config_msg;
  common::DaqConfigDecoder config_decoder;
};

}  // namespace rocklab::monitor
