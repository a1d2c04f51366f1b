#include "monitor/live_state.h"

#include <algorithm>
#include <array>
#include <map>
#include <stdexcept>
#include <string_view>
#include <utility>
#include <vector>

#include "compare/ring.h"
#include "rocklab/block_state_t.hpp"
#include "rocklab/comparison_t.hpp"
#include "rocklab/daq_config_t.hpp"
#include "rocklab/event_t.hpp"
#include "rocklab/health_t.hpp"
#include "rocklab/model_state_t.hpp"

namespace rocklab::monitor {
namespace {

using nlohmann::json;
using compare::Ring;

constexpr double kDegPerRad = 180.0 / 3.14159265358979323846;
constexpr std::size_t kGrowingInitialCapacity = 4096;
constexpr std::size_t kMaxTextBytes = 256;  // event details and names are cut here

bool StartsWith(std::string_view s, std::string_view prefix) {
  return s.size() >= prefix.size() && s.substr(0, prefix.size()) == prefix;
}

// The block-state flags the page shows as bands, in this order.
struct FlagBit {
  std::int32_t bit;
  const char* name;
};
constexpr std::array<FlagBit, 3> kFlagBits{{{rocklab::block_state_t::FLAG_SLIDING, "sliding"},
                                            {rocklab::block_state_t::FLAG_JUMP, "jump"},
                                            {rocklab::block_state_t::FLAG_TWIST, "twist"}}};
constexpr std::int8_t kStaleFlag = static_cast<std::int8_t>(kFlagBits.size());  // index past the bits

const char* FlagName(std::int8_t flag) {
  return flag == kStaleFlag ? "stale" : kFlagBits[static_cast<std::size_t>(flag)].name;
}

const char* EventKindName(std::int8_t kind) {
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

// Assigns at most kMaxTextBytes: a text field of a message cannot grow the state.
void AssignText(std::string& to, const std::string& from) {
  to.assign(from, 0, std::min(from.size(), kMaxTextBytes));
}

// daq_config_t holds num_channels-long arrays that its generated decoder
// resizes before reading them: refuse a count the payload cannot hold.
bool DaqConfigCountFits(const void* data, int size) {
  const auto* b = static_cast<const std::uint8_t*>(data);
  long pos = 16;  // fingerprint, utime
  auto int32_at = [&](long at, std::int32_t& out) {
    if (at < 0 || at + 4 > size) return false;
    out = static_cast<std::int32_t>((std::uint32_t{b[at]} << 24) | (std::uint32_t{b[at + 1]} << 16) |
                                    (std::uint32_t{b[at + 2]} << 8) | std::uint32_t{b[at + 3]});
    return true;
  };
  for (int text = 0; text < 2; ++text) {  // rig_name, calibration_id
    std::int32_t len = 0;
    if (!int32_at(pos, len) || len < 1) return false;
    pos += 4 + len;
  }
  pos += 8;  // sample_rate_hz
  std::int32_t n = 0;
  if (!int32_at(pos, n) || n < 0) return false;
  // Each channel takes at least three 5-byte strings and two doubles.
  constexpr long kMinChannelBytes = 3 * 5 + 2 * 8;
  return static_cast<long>(n) * kMinChannelBytes <= size - (pos + 4);
}

// One point of a series: two values at one sample-clock time.
struct Point {
  std::uint64_t seq{};   // LiveState change number when stored
  std::int64_t utime{};  // sample clock, us
  double a{};
  double b{};
};

// A decimated time series in a ring: at most one point per 1/rate slot of
// the sample clock (the first sample of the slot). A growing series (the
// whole record) doubles its ring when full.
class Series {
 public:
  Series(std::size_t capacity, bool grows) : ring_(capacity), grows_(grows) {}

  enum class Outcome { kStored, kDecimated, kOutOfOrder };
  Outcome Add(std::uint64_t seq, std::int64_t utime, std::int64_t t0, double period_us, double a,
              double b) {
    const auto slot = static_cast<std::int64_t>(std::floor(static_cast<double>(utime - t0) / period_us));
    if (!ring_.empty()) {
      if (utime <= ring_.back().utime) return Outcome::kOutOfOrder;
      if (slot <= last_slot_) return Outcome::kDecimated;
    }
    if (grows_ && ring_.full()) Grow();
    ring_.push_back(Point{seq, utime, a, b});
    last_slot_ = slot;
    return Outcome::kStored;
  }

  void Clear() {
    while (!ring_.empty()) ring_.pop_front();
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
  void Grow() {
    Ring<Point> bigger(ring_.capacity() * 2);
    for (std::size_t i = 0; i < ring_.size(); ++i) bigger.push_back(ring_[i]);
    ring_ = std::move(bigger);
  }

  Ring<Point> ring_;
  bool grows_;
  std::int64_t last_slot_{};
};

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
};

}  // namespace

void LiveOptions::Validate() const {
  auto check = [](bool ok, const char* name) {
    if (!ok) throw std::invalid_argument(std::string("monitor option ") + name + " out of range");
  };
  check(window_s > 0 && !std::isnan(window_s), "window_s");
  check(std::isfinite(series_rate_hz) && series_rate_hz > 0, "series_rate_hz");
  check(!std::isfinite(window_s) || window_s * series_rate_hz < 1e8, "window_s * series_rate_hz");
  check(max_events >= 1, "max_events");
  check(max_intervals >= 1, "max_intervals");
  check(max_variants >= 1, "max_variants");
  check(max_nodes >= 1, "max_nodes");
  check(max_channels >= 1, "max_channels");
  check(std::isfinite(new_record_after_s) && new_record_after_s > 0, "new_record_after_s");
}

struct LiveState::Impl {
  struct Variant {
    Variant(std::string_view n, std::size_t capacity, bool grows)
        : name(n), theta(capacity, grows), comparison(capacity, grows) {}
    std::string name;
    bool has_params{};
    rocklab::model_state_t params;  // the newest RL_MODEL_<name>: model, alpha, p, mu, l
    Series theta;       // a: theta, deg
    Series comparison;  // a: error, deg; b: rms_window, deg
    bool has_latest{};
    rocklab::comparison_t latest;
  };

  explicit Impl(const LiveOptions& o)
      : options(o),
        grows(!std::isfinite(o.window_s)),
        capacity(grows ? kGrowingInitialCapacity
                       : static_cast<std::size_t>(std::ceil(o.window_s * o.series_rate_hz)) + 2),
        period_us(1e6 / o.series_rate_hz),
        measured(capacity, grows),
        intervals(o.max_intervals),
        events(o.max_events) {}

  // -- ingestion ------------------------------------------------------------

  bool Ingest(std::string_view channel, const void* data, int size);
  bool IngestTheta(const void* data, int size);
  bool IngestModel(std::string_view name, const void* data, int size);
  bool IngestCompare(std::string_view name, const void* data, int size);
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
    variants.push_back(std::make_unique<Variant>(name, capacity, grows));
    by_name.emplace(std::string(name), variants.back().get());
    return variants.back().get();
  }

  // A time from the wire may become the origin: beyond +-2^53 us (285 years)
  // it is corrupt, and differences of such times overflow int64. Refused as a
  // decode error (counted per channel).
  static bool UsableUtime(std::int64_t utime) {
    constexpr std::int64_t kMaxAbsUtime = std::int64_t{1} << 53;
    return utime >= -kMaxAbsUtime && utime <= kMaxAbsUtime;
  }

  // A sample-clock reading of a series: sets t0, starts a new record when
  // the clock went back by more than new_record_after_s.
  void SeeSampleClock(std::int64_t utime) {
    if (has_clock && static_cast<double>(utime) <
                         static_cast<double>(latest_utime) - options.new_record_after_s * 1e6) {
      NewRecord();
    }
    if (!has_clock) {
      has_clock = true;
      t0_utime = latest_utime = utime;
    }
    latest_utime = std::max(latest_utime, utime);
  }

  // Decodes a message of a series into `msg` and reads its sample clock.
  template <class Msg>
  bool DecodeSample(Msg& msg, const void* data, int size) {
    if (msg.decode(data, 0, size) < 0 || !UsableUtime(msg.utime)) return false;
    SeeSampleClock(msg.utime);
    return true;
  }

  void NewRecord() {
    ++record;
    record_start_seq = seq;  // the change being ingested belongs to the new record
    has_clock = false;
    measured.Clear();
    variants.clear();
    by_name.clear();
    while (!intervals.empty()) intervals.pop_front();
    while (!events.empty()) events.pop_front();
    open_flags.fill(0);
    open_stale.clear();
  }

  void AddPoint(Series& s, std::int64_t utime, double a, double b) {
    if (s.Add(seq, utime, t0_utime, period_us, a, b) == Series::Outcome::kOutOfOrder) {
      ++dropped_out_of_order;
    }
  }

  std::uint64_t OpenInterval(std::int8_t flag, const std::string& source, std::int64_t utime) {
    Interval& iv = interval_scratch;
    iv.id = ++last_interval_id;
    iv.seq = seq;
    iv.flag = flag;
    AssignText(iv.source, source);
    iv.start = iv.end = utime;
    iv.open = true;
    if (!intervals.push_back(iv)) ++dropped_intervals;
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

  Series measured;  // a: theta, deg
  std::vector<std::unique_ptr<Variant>> variants;  // in order of appearance
  std::map<std::string, Variant*, std::less<>> by_name;

  Ring<Interval> intervals;
  Interval interval_scratch;
  std::uint64_t last_interval_id{};
  std::array<std::uint64_t, kFlagBits.size()> open_flags{};  // interval id, 0: none
  std::map<std::string, std::uint64_t, std::less<>> open_stale;  // source -> interval id

  Ring<Event> events;
  Event event_scratch;
  std::map<std::string, rocklab::health_t, std::less<>> health;  // by node

  bool has_config{};
  std::string rig_name, calibration_id;
  double sample_rate_hz{}, alpha{}, p{}, mu{};

  std::map<std::string, ChannelCount, std::less<>> channels;
  std::int64_t dropped_out_of_order{}, dropped_intervals{}, dropped_events{},
      dropped_variants{}, dropped_nodes{}, dropped_channels{};

  // Decoding buffers, reused: strings keep their capacity.
  rocklab::block_state_t theta_msg;
  rocklab::model_state_t model_msg;
  rocklab::comparison_t compare_msg;
  rocklab::event_t event_msg;
  rocklab::health_t health_msg;
  rocklab::daq_config_t config_msg;
};

bool LiveState::Impl::Ingest(std::string_view channel, const void* data, int size) {
  ++seq;
  ChannelCount* count = CountFor(channel);
  if (count) ++count->messages;
  if (!StartsWith(channel, options.channel_prefix)) return false;
  const std::string_view kind = channel.substr(options.channel_prefix.size());
  bool known = true;
  bool ok = false;
  try {
    if (kind == "THETA") {
      ok = IngestTheta(data, size);
    } else if (StartsWith(kind, "MODEL_") && kind.size() > 6) {
      ok = IngestModel(kind.substr(6), data, size);
    } else if (StartsWith(kind, "COMPARE_") && kind.size() > 8) {
      ok = IngestCompare(kind.substr(8), data, size);
    } else if (kind == "EVENT") {
      ok = IngestEvent(data, size);
    } else if (kind == "HEALTH") {
      ok = IngestHealth(data, size);
    } else if (kind == "DAQ_CONFIG") {
      ok = IngestConfig(data, size);
    } else {
      known = false;
    }
  } catch (const std::exception&) {
    ok = false;  // a generated decoder refusing a length: a decode error like any other
  }
  if (known && !ok && count) ++count->decode_errors;
  return known && ok;
}

bool LiveState::Impl::IngestTheta(const void* data, int size) {
  if (!DecodeSample(theta_msg, data, size)) return false;
  const rocklab::block_state_t& m = theta_msg;
  AddPoint(measured, m.utime, m.theta * kDegPerRad, 0.0);
  for (std::size_t i = 0; i < kFlagBits.size(); ++i) {
    const bool raised = (m.flags & kFlagBits[i].bit) != 0;
    if (raised && open_flags[i] == 0) {
      open_flags[i] = OpenInterval(static_cast<std::int8_t>(i), "daq", m.utime);
    } else if (!raised && open_flags[i] != 0) {
      CloseInterval(open_flags[i], m.utime);
      open_flags[i] = 0;
    }
  }
  return true;
}

bool LiveState::Impl::IngestModel(std::string_view name, const void* data, int size) {
  if (!DecodeSample(model_msg, data, size)) return false;
  Variant* v = VariantFor(name);
  if (!v) return true;  // counted in dropped.variants
  v->has_params = true;
  v->params = model_msg;  // copies reuse the strings' capacity
  AddPoint(v->theta, model_msg.utime, model_msg.theta * kDegPerRad, 0.0);
  return true;
}

bool LiveState::Impl::IngestCompare(std::string_view name, const void* data, int size) {
  if (!DecodeSample(compare_msg, data, size)) return false;
  Variant* v = VariantFor(name);
  if (!v) return true;
  const rocklab::comparison_t& m = compare_msg;
  AddPoint(v->comparison, m.utime, m.error * kDegPerRad, m.rms_window * kDegPerRad);
  v->has_latest = true;
  v->latest = m;
  return true;
}

bool LiveState::Impl::IngestEvent(const void* data, int size) {
  if (event_msg.decode(data, 0, size) < 0 || !UsableUtime(event_msg.utime)) return false;
  const rocklab::event_t& m = event_msg;
  if (!has_clock) {
    has_clock = true;
    t0_utime = latest_utime = m.utime;
  }
  latest_utime = std::max(latest_utime, m.utime);
  // Filled in place, then copied into the ring's slot: the copy reuses the
  // slot's string capacity once the ring has gone round.
  Event& e = event_scratch;
  e.seq = seq;
  e.utime = m.utime;
  AssignText(e.source, m.source);
  e.kind = m.kind;
  e.value = m.value;
  AssignText(e.detail, m.detail);
  if (!events.push_back(e)) ++dropped_events;

  // Keyed by the stored (bounded) source text, as the interval holds it.
  if (m.kind == rocklab::event_t::STALE && open_stale.find(e.source) == open_stale.end()) {
    if (open_stale.size() < options.max_nodes) {
      const std::uint64_t id = OpenInterval(kStaleFlag, m.source, m.utime);
      open_stale.emplace(intervals[intervals.size() - 1].source, id);
    } else {
      ++dropped_intervals;
    }
  } else if (m.kind == rocklab::event_t::RECOVERED) {
    // RECOVERED closes the source's stale interval when one is open (the DAQ
    // also sends RECOVERED when a sliding/twist check passes again; those
    // flags come from RL_THETA instead).
    auto it = open_stale.find(e.source);
    if (it != open_stale.end()) {
      CloseInterval(it->second, m.utime);
      open_stale.erase(it);
    }
  }
  return true;
}

bool LiveState::Impl::IngestHealth(const void* data, int size) {
  if (health_msg.decode(data, 0, size) < 0) return false;
  auto it = health.find(health_msg.node);
  if (it == health.end()) {
    if (health.size() >= options.max_nodes) {
      ++dropped_nodes;
      return true;
    }
    it = health.emplace(health_msg.node, rocklab::health_t{}).first;
  }
  it->second = health_msg;
  return true;
}

bool LiveState::Impl::IngestConfig(const void* data, int size) {
  if (!DaqConfigCountFits(data, size) || config_msg.decode(data, 0, size) < 0) return false;
  has_config = true;
  AssignText(rig_name, config_msg.rig_name);
  AssignText(calibration_id, config_msg.calibration_id);
  sample_rate_hz = config_msg.sample_rate_hz;
  alpha = config_msg.alpha;
  p = config_msg.p;
  mu = config_msg.mu;
  return true;
}

json LiveState::Impl::Update(std::uint64_t cursor) const {
  const bool full = cursor == 0 || cursor < record_start_seq;
  const bool windowed = std::isfinite(options.window_s) && has_clock;
  const std::int64_t from_utime =
      windowed ? latest_utime - static_cast<std::int64_t>(std::llround(options.window_s * 1e6))
               : std::numeric_limits<std::int64_t>::min();
  auto first = [&](const Series& s) { return full ? s.FirstFrom(from_utime) : s.FirstAfter(cursor); };
  auto number = [](double x) { return std::isfinite(x) ? json(x) : json(nullptr); };

  // One series as {"t": [...], "<a_name>": [...] (, "<b_name>": [...])}.
  auto series = [&](const Series& s, const char* a_name, const char* b_name) {
    json t = json::array(), a = json::array(), b = json::array();
    for (std::size_t i = first(s); i < s.size(); ++i) {
      t.push_back(T(s[i].utime));
      a.push_back(number(s[i].a));
      if (b_name) b.push_back(number(s[i].b));
    }
    json out = {{"t", std::move(t)}, {a_name, std::move(a)}};
    if (b_name) out[b_name] = std::move(b);
    return out;
  };

  json doc;
  doc["schema"] = "rocklab.monitor.v1";
  doc["full"] = full;
  doc["cursor"] = seq;
  doc["record"] = record;
  doc["t0_utime"] = has_clock ? json(t0_utime) : json(nullptr);
  doc["t_latest"] = has_clock ? json(T(latest_utime)) : json(nullptr);
  doc["window_s"] = number(options.window_s);
  doc["series_rate_hz"] = options.series_rate_hz;
  doc["measured"] = series(measured, "theta_deg", nullptr);

  json variant_list = json::array();
  for (const auto& v : variants) {
    json j = {{"name", v->name}};
    if (v->has_params) {
      j["model"] = v->params.model;
      j["alpha"] = number(v->params.alpha);
      j["p"] = number(v->params.p);
      j["mu"] = number(v->params.mu);
      j["l"] = number(v->params.l);
    } else {
      for (const char* k : {"model", "alpha", "p", "mu", "l"}) j[k] = nullptr;
    }
    j["theta"] = series(v->theta, "theta_deg", nullptr);
    j["comparison"] = series(v->comparison, "error_deg", "rms_window_deg");
    if (v->has_latest) {
      const rocklab::comparison_t& m = v->latest;
      j["latest"] = {{"utime", m.utime},
                     {"t", T(m.utime)},
                     {"error", number(m.error)},
                     {"rms_window", number(m.rms_window)},
                     {"window_s", number(m.window_s)},
                     {"rms_total", number(m.rms_total)},
                     {"nrms", number(m.nrms)},
                     {"peak_error", number(m.peak_error)},
                     {"impact_timing_error", number(m.impact_timing_error)},
                     {"correlation", number(m.correlation)},
                     {"valid", m.valid != 0},
                     {"samples", m.samples}};
    } else {
      j["latest"] = nullptr;
    }
    variant_list.push_back(std::move(j));
  }
  doc["variants"] = std::move(variant_list);

  json flags = json::array();
  for (std::size_t i = 0; i < intervals.size(); ++i) {
    const Interval& iv = intervals[i];
    const bool wanted = full ? (iv.open || iv.end >= from_utime) : iv.seq > cursor;
    if (!wanted) continue;
    flags.push_back({{"id", iv.id},
                     {"flag", FlagName(iv.flag)},
                     {"source", iv.source},
                     {"start", T(iv.start)},
                     {"end", iv.open ? json(nullptr) : json(T(iv.end))}});
  }
  doc["flags"] = std::move(flags);

  json event_list = json::array();
  for (std::size_t i = 0; i < events.size(); ++i) {
    const Event& e = events[i];
    if (full ? e.utime < from_utime : e.seq <= cursor) continue;
    event_list.push_back({{"t", T(e.utime)},
                          {"utime", e.utime},
                          {"source", e.source},
                          {"kind", EventKindName(e.kind)},
                          {"code", e.kind},
                          {"value", number(e.value)},
                          {"detail", e.detail}});
  }
  doc["events"] = std::move(event_list);

  json health_list = json::array();
  for (const auto& [node, h] : health) {
    health_list.push_back({{"node", node}, {"state", h.state}, {"utime", h.utime},
                           {"rate_in_hz", number(h.rate_in_hz)}, {"rate_out_hz", number(h.rate_out_hz)},
                           {"count_in", h.count_in}, {"count_out", h.count_out},
                           {"dropped", h.dropped}, {"gaps", h.gaps}, {"bad_samples", h.bad_samples},
                           {"lag_s", number(h.lag_s)}});
  }
  doc["health"] = std::move(health_list);

  doc["config"] = has_config ? json{{"rig_name", rig_name},
                                    {"calibration_id", calibration_id},
                                    {"sample_rate_hz", number(sample_rate_hz)},
                                    {"alpha", number(alpha)},
                                    {"p", number(p)},
                                    {"mu", number(mu)}}
                             : json(nullptr);

  json messages = json::object(), decode_errors = json::object();
  for (const auto& [channel, c] : channels) {
    messages[channel] = c.messages;
    decode_errors[channel] = c.decode_errors;
  }
  doc["counters"] = {{"messages", std::move(messages)},
                     {"decode_errors", std::move(decode_errors)},
                     {"dropped",
                      {{"out_of_order", dropped_out_of_order},
                       {"events", dropped_events},
                       {"intervals", dropped_intervals},
                       {"variants", dropped_variants},
                       {"nodes", dropped_nodes},
                       {"channels", dropped_channels}}}};
  doc["units"] = {{"t", "s"}, {"t_latest", "s"}, {"t0_utime", "us"}, {"utime", "us"},
                  {"window_s", "s"}, {"series_rate_hz", "Hz"}, {"theta_deg", "deg"},
                  {"error_deg", "deg"}, {"rms_window_deg", "deg"}, {"error", "rad"},
                  {"rms_window", "rad"}, {"rms_total", "rad"}, {"nrms", "1"},
                  {"peak_error", "rad"}, {"impact_timing_error", "s"}, {"correlation", "1"},
                  {"alpha", "rad"}, {"p", "rad/s"}, {"mu", "1"}, {"l", "1"},
                  {"sample_rate_hz", "Hz"}, {"rate_in_hz", "Hz"}, {"rate_out_hz", "Hz"},
                  {"lag_s", "s"}, {"start", "s"}, {"end", "s"},
                  {"value", "per event kind, see lcm_types/event.lcm"}};
  return doc;
}

LiveState::LiveState(const LiveOptions& options) : options_(options) {
  options_.Validate();
  impl_ = std::make_unique<Impl>(options_);
}

LiveState::~LiveState() = default;

bool LiveState::Ingest(const std::string& channel, const void* data, int size) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!data || size < 0) size = 0;
  return impl_->Ingest(channel, data ? data : "", size);
}

nlohmann::json LiveState::Snapshot() const { return UpdateSince(0); }

nlohmann::json LiveState::UpdateSince(std::uint64_t cursor) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return impl_->Update(cursor);
}

std::uint64_t LiveState::cursor() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return impl_->seq;
}

std::size_t LiveState::SeriesCapacity() const { return impl_->grows ? 0 : impl_->capacity; }

}  // namespace rocklab::monitor
