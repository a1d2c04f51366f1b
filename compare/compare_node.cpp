#include "compare/compare_node.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

#include <time.h>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "common/atomic_file.h"
#include "common/node_support.h"
#include "common/units.h"
#include "common/versions.h"
#include "rocklab/band_comparison_t.hpp"
#include "rocklab/comparison2_t.hpp"
#include "rocklab/comparison3_t.hpp"
#include "rocklab/event2_t.hpp"
#include "rocklab/event_t.hpp"
#include "rocklab/health2_t.hpp"

namespace rocklab::compare {
namespace {

// A non-negative count computed in double, capped at INT64_MAX.
std::int64_t CountOf(double n) {
  return n >= 9.2e18 ? std::numeric_limits<std::int64_t>::max() : n <= 0 ? 0 : static_cast<std::int64_t>(n);
}

// The host clock of the stale checks, read at every RL_THETA and
// RL_MODEL_* (six times a sample in `run` with four variants): the kernel's
// coarse monotonic clock, which resolves its tick (~4 ms) at a third of
// steady_clock's cost (docs/performance.md); stale_after_s is seconds.
double CompareHostNowS() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC_COARSE, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

std::shared_ptr<spdlog::logger> Log() {
  static const std::shared_ptr<spdlog::logger> log = common::NamedLogger("compare");
  return log;
}

// A metric without a value (NaN: no crossing matched) is null in JSON; the
// key stays.
nlohmann::json OrNull(double v) { return std::isnan(v) ? nlohmann::json(nullptr) : nlohmann::json(v); }

}  // namespace

void CompareNodeConfig::Validate() const {
  auto check = [](bool ok, const char* name) {
    if (!ok) throw std::invalid_argument(std::string("compare option ") + name + " out of range");
  };
  check(std::isfinite(publish_rate_hz) && publish_rate_hz > 0, "publish_rate_hz");
  check(std::isfinite(stale_after_s) && stale_after_s > 0, "stale_after_s");
  check(std::isfinite(health_period_s) && health_period_s > 0, "health_period_s");
  check(align_capacity >= 2, "align_capacity");
  check(subscriber_queue >= 1, "subscriber_queue");
  check(std::isfinite(mode_rest_rad) && mode_rest_rad >= 0, "mode_rest_rad");
  comparator.Validate();
}

struct CompareNode::Variant {
  Variant(const CompareNodeConfig& c, const rocklab::model_state3_t& first)
      : name(first.name), model(first.model), channel(c.channel_prefix + "COMPARE_" + first.name),
        alpha(first.alpha), p(first.p), mu(first.mu), comparator(c.comparator),
        pending(c.align_capacity) {}
  std::string name, model, channel;
  double alpha, p, mu;
  Comparator comparator;
  struct Pending {
    std::int64_t utime{};
    double theta{};
  };
  common::Ring<Pending> pending;  // model samples newer than every measured one
  std::int64_t pairs{};
  std::int64_t unmatched_model{};
  std::int64_t last_pub_utime{INT64_MIN};
  bool dirty{};  // paired since the last publish
  double last_host_s{};
  std::int64_t last_utime{INT64_MIN};  // newest model utime, us
  bool stale{};
  common::SeqGaps model_seq;      // RL_MODEL_<name>'s seq
  std::int64_t compare_seq{};     // seq of the next RL_COMPARE_<name>
};

struct CompareNode::Band {
  Band(const CompareNodeConfig& c, const rocklab::model_band_t& first)
      : name(first.name), model(first.model), channel(c.channel_prefix + "COVERAGE_" + first.name),
        draws(first.draws), comparator(c.comparator), pending(c.align_capacity) {}
  std::string name, model, channel;
  std::int32_t draws{}, members{};
  BandComparator comparator;
  struct Pending {
    std::int64_t utime{};
    BandSample band;
  };
  common::Ring<Pending> pending;  // band samples newer than every measured one
  std::int64_t pairs{};
  std::int64_t unmatched_model{};
  std::int64_t last_pub_utime{INT64_MIN};
  bool dirty{};
  common::SeqGaps seq;         // RL_BAND_<name>'s seq
  std::int64_t coverage_seq{}; // seq of the next RL_COVERAGE_<name>
};

// A measured sample of every body (RL_BODIES), its angles and validity.
struct CompareNode::BodiesMeasured {
  std::int64_t utime{};
  int n{};
  std::array<double, kMaxCompareBodies> theta{};
  std::array<bool, kMaxCompareBodies> valid{};
};

// An assembly variant's sample: its angles and mode ("" unknown; a mode
// longer than kMaxCompareBodies cannot name n interfaces and is kept "").
struct CompareNode::BodiesModelSample {
  std::int64_t utime{};
  int n{};
  std::array<double, kMaxCompareBodies> theta{};
  std::array<char, kMaxCompareBodies> mode{};
  int mode_length{};
};

struct CompareNode::BodiesVariant {
  BodiesVariant(const CompareNodeConfig& c, const rocklab::model_state4_t& first)
      : name(first.name), channel(c.channel_prefix + "COMPAREBODIES_" + first.name),
        n(first.nbodies), comparator(first.nbodies, BodiesComparatorOptions{c.comparator, c.mode_rest_rad}),
        pending(c.align_capacity) {
    mode.reserve(kMaxCompareBodies);
  }
  std::string name, channel;
  int n;
  BodiesComparator comparator;
  common::Ring<BodiesModelSample> pending;  // samples newer than every measured one
  std::string mode;                         // the pair's model mode, reused
  std::int64_t pairs{};
  std::int64_t unmatched_model{};  // never paired: no measured sample of its utime, or of other nbodies
  std::int64_t last_pub_utime{INT64_MIN};
  bool dirty{};
  std::int64_t compare_seq{};  // seq of the next RL_COMPAREBODIES_<name>
};

namespace {

BandSample ToBandSample(const rocklab::model_band_t& m) {
  BandSample b;
  b.lo95 = m.theta_lo95;
  b.lo68 = m.theta_lo68;
  b.median = m.theta_median;
  b.hi68 = m.theta_hi68;
  b.hi95 = m.theta_hi95;
  b.impacts_up = m.impacts_up;
  b.up_offset_sum = m.impact_up_offset_sum;
  b.up_offset_sq_sum = m.impact_up_offset_sq_sum;
  b.impacts_down = m.impacts_down;
  b.down_offset_sum = m.impact_down_offset_sum;
  b.down_offset_sq_sum = m.impact_down_offset_sq_sum;
  return b;
}

}  // namespace

CompareNode::CompareNode(const CompareNodeConfig& config, common::Bus& bus)
    : config_(config), bus_(bus), measured_(config.align_capacity) {
  config_.Validate();
  last_theta_host_s_ = last_health_host_s_ = CompareHostNowS();
  subscriptions_.push_back(bus_.Subscribe<rocklab::block_state_t>(
      config_.channel_prefix + "THETA",
      [this](const std::string&, const rocklab::block_state_t& m) {
        HandleTheta(m);
        CheckStale();  // on a DirectBus nobody runs the idle loop
      },
      config_.subscriber_queue));
  // model_state3_t from the model node, model_state2_t or model_state_t from older logs.
  // model_state4_t (an assembly, or a single block as nbodies = 1) read as
  // is; model_state3_t from the model node, model_state2_t or model_state_t
  // from older logs read as it with nbodies = 1.
  subscriptions_.push_back(common::SubscribeVersioned<common::ModelStateBodiesDecoder>(
      bus_, config_.channel_prefix + "MODEL_.*",
      [this](const std::string&, const rocklab::model_state4_t& m) { HandleModelBodies(m); },
      config_.subscriber_queue));
  subscriptions_.push_back(bus_.Subscribe<rocklab::block_state2_t>(
      config_.channel_prefix + "BODIES",
      [this](const std::string&, const rocklab::block_state2_t& m) { HandleBodies(m); },
      config_.subscriber_queue));
  subscriptions_.push_back(bus_.Subscribe<rocklab::model_band_t>(
      config_.channel_prefix + "BAND_.*",
      [this](const std::string&, const rocklab::model_band_t& m) { HandleBand(m); },
      config_.subscriber_queue));
}

CompareNode::~CompareNode() {
  subscriptions_.clear();  // no handler runs from here on
}

CompareNode::Variant& CompareNode::VariantFor(const rocklab::model_state3_t& msg) {
  auto it = variants_.find(msg.name);
  if (it != variants_.end()) return *it->second;
  auto v = std::make_unique<Variant>(config_, msg);
  Variant& ref = *v;
  order_.push_back(&ref);
  variants_.emplace(msg.name, std::move(v));
  Log()->info("comparing variant '{}' ({}, alpha {:.4f} rad, p {:.4f} rad/s, mu {:.4f})",
              msg.name, msg.model, msg.alpha, msg.p, msg.mu);
  return ref;
}

void CompareNode::HandleTheta(const rocklab::block_state_t& msg) {
  const double now = CompareHostNowS();
  if (theta_stale_) {
    theta_stale_ = false;
    PublishEvent(rocklab::event_t::RECOVERED, "daq", 0.0, "RL_THETA flowing again");
  }
  last_theta_host_s_ = now;
  // Gaps: a forward jump of the DAQ's seq (a repeat or a step back is a
  // restart or a duplicate, counted below as out of order when its time is).
  theta_seq_.Add(msg.seq);
  if (last_theta_utime_ != INT64_MIN && msg.utime > last_theta_utime_ &&
      static_cast<double>(msg.utime) - static_cast<double>(last_theta_utime_) < 9e18) {
    const std::int64_t step = msg.utime - last_theta_utime_;  // the sample period: the smallest step
    if (period_us_ == 0 || step < period_us_) period_us_ = step;
  }
  last_theta_utime_ = msg.utime;
  if (!measured_.empty() && msg.utime <= measured_.back().utime) {
    ++theta_out_of_order_;  // the DAQ stamps in order: a duplicate or a replay restart
    return;
  }
  ++theta_count_;
  newest_utime_ = std::max(newest_utime_, msg.utime);
  const bool valid = (msg.flags & config_.invalid_flags) == 0 && std::isfinite(msg.theta);
  measured_.push_back({msg.utime, msg.theta, valid});
  // The model-side samples waiting for this one: paired, or (older, their
  // measured sample never came) counted.
  auto drain = [&](auto& stream, auto pair) {
    while (!stream.pending.empty() && stream.pending.front().utime <= msg.utime) {
      const auto waiting = stream.pending.front();
      stream.pending.pop_front();
      if (waiting.utime == msg.utime) {
        pair(waiting);
      } else {
        ++stream.unmatched_model;
      }
    }
  };
  for (Variant* v : order_) {
    drain(*v, [&](const Variant::Pending& pm) { Pair(*v, msg.utime, msg.theta, valid, pm.theta); });
  }
  for (Band* b : band_order_) {
    drain(*b, [&](const Band::Pending& pb) { PairBand(*b, msg.utime, msg.theta, valid, pb.band); });
  }
}

bool CompareNode::PublishDue(std::int64_t utime, std::int64_t last_pub_utime) const {
  const double period_us = 1e6 / config_.publish_rate_hz;
  return last_pub_utime == INT64_MIN ||
         static_cast<double>(utime) - static_cast<double>(last_pub_utime) >= period_us - 0.5;
}

std::size_t CompareNode::FindMeasured(std::int64_t utime) const {
  // The model's sample is nearly always one of the newest measured ones (it
  // follows the table sample the measurement came with): look there first,
  // then binary search the ring (utime increasing). The search was 7.5 % of
  // `run --max`'s CPU with four variants (docs/performance.md).
  const std::size_t n = measured_.size();
  for (std::size_t back = 1; back <= std::min<std::size_t>(n, 4); ++back) {
    const std::int64_t u = measured_[n - back].utime;
    if (u == utime) return n - back;
    if (u < utime) return n;  // between two measured samples: none has it
  }
  std::size_t lo = 0, hi = n;
  while (lo < hi) {
    const std::size_t mid = (lo + hi) / 2;
    if (measured_[mid].utime < utime) {
      lo = mid + 1;
    } else {
      hi = mid;
    }
  }
  return lo < measured_.size() && measured_[lo].utime == utime ? lo : measured_.size();
}

void CompareNode::CountSeq(common::SeqGaps& gaps, std::int64_t seq) {
  const std::int64_t before = gaps.missing();
  gaps.Add(seq);
  model_gaps_ = common::SeqGaps::SaturatingAdd(model_gaps_, gaps.missing() - before);
}

CompareNode::Band& CompareNode::BandFor(const rocklab::model_band_t& msg) {
  auto it = bands_.find(msg.name);
  if (it != bands_.end()) return *it->second;
  auto b = std::make_unique<Band>(config_, msg);
  Band& ref = *b;
  band_order_.push_back(&ref);
  bands_.emplace(msg.name, std::move(b));
  Log()->info("comparing band '{}' ({}, {} draws)", msg.name, msg.model, msg.draws);
  return ref;
}

void CompareNode::HandleBand(const rocklab::model_band_t& msg) {
  ++model_count_;
  Band& b = BandFor(msg);
  CountSeq(b.seq, msg.seq);
  b.members = msg.members;
  newest_utime_ = std::max(newest_utime_, msg.utime);
  const BandSample band = ToBandSample(msg);
  if (measured_.empty() || msg.utime > measured_.back().utime) {
    if (!b.pending.push_back({msg.utime, band})) ++b.unmatched_model;
    return;
  }
  const std::size_t i = FindMeasured(msg.utime);
  if (i < measured_.size()) {
    PairBand(b, measured_[i].utime, measured_[i].theta, measured_[i].valid, band);
  } else {
    ++b.unmatched_model;
  }
}

void CompareNode::PairBand(Band& b, std::int64_t utime, double measured, bool valid,
                           const BandSample& band) {
  ++b.pairs;
  b.comparator.Add(utime, measured, valid, band);
  b.dirty = true;
  if (PublishDue(utime, b.last_pub_utime)) PublishCoverage(b);
}

void CompareNode::PublishCoverage(Band& b) {
  const BandMetrics& m = b.comparator.metrics();
  b.last_pub_utime = m.utime;
  b.dirty = false;
  rocklab::band_comparison_t out;
  out.utime = m.utime;
  out.seq = b.coverage_seq++;
  out.name = b.name;
  out.window_s = config_.comparator.window_s;
  out.coverage95_window = m.coverage95_window;
  out.coverage95_total = m.coverage95_total;
  out.coverage68_window = m.coverage68_window;
  out.coverage68_total = m.coverage68_total;
  out.median_error = m.median_error;
  out.width95 = m.width95;
  out.impact_timing_z = m.impact_timing_z;
  out.impact_time_sd = m.impact_time_sd;
  out.impact_timing_z_rms = m.impact_timing_z_rms;
  out.matched_crossings = m.matched_crossings;
  out.unmatched_crossings = m.unmatched_crossings;
  out.valid = m.valid;
  out.samples = m.samples;
  out.valid_samples = m.valid_samples;
  bus_.Publish(b.channel, out);
  ++published_;
}

void CompareNode::HandleModel(const rocklab::model_state3_t& msg) {
  ++model_count_;
  Variant& v = VariantFor(msg);
  v.last_host_s = CompareHostNowS();
  if (v.stale) {
    v.stale = false;
    PublishEvent(rocklab::event_t::RECOVERED, msg.name, 0.0, "model flowing again");
  }
  // Gaps: a forward jump of the model node's seq. Older types have none: a
  // gap is then a step of the sample clock over 1.5 sample periods (one
  // message per table sample).
  if (msg.seq != common::kNoSeq) {
    CountSeq(v.model_seq, msg.seq);
  } else if (v.last_utime != INT64_MIN && period_us_ > 0 && msg.utime > v.last_utime) {
    // In double: utimes come off the wire, their difference may not fit.
    const double periods = (static_cast<double>(msg.utime) - static_cast<double>(v.last_utime)) /
                           static_cast<double>(period_us_);
    if (periods > 1.5) model_gaps_ = common::SeqGaps::SaturatingAdd(model_gaps_, CountOf(std::floor(periods + 0.5) - 1));
  }
  v.last_utime = std::max(v.last_utime, msg.utime);
  newest_utime_ = std::max(newest_utime_, msg.utime);
  if (config_.stale_clock == StaleClock::kSample) CheckStale();
  if (measured_.empty() || msg.utime > measured_.back().utime) {
    if (!v.pending.push_back({msg.utime, msg.theta})) ++v.unmatched_model;
    return;
  }
  const std::size_t lo = FindMeasured(msg.utime);
  if (lo < measured_.size()) {
    const Measured& m = measured_[lo];
    Pair(v, m.utime, m.theta, m.valid, msg.theta);
  } else {
    ++v.unmatched_model;
  }
}

void CompareNode::HandleModelBodies(const rocklab::model_state4_t& msg) {
  const std::size_t n = msg.nbodies > 0 ? static_cast<std::size_t>(msg.nbodies) : 0;
  // Decoded messages have every array of nbodies; a caller's may not.
  bool arrays_fit = true;
  for (const auto* a : {&msg.theta, &msg.theta_dot, &msg.chi, &msg.psi, &msg.alpha, &msg.p, &msg.mu}) {
    arrays_fit = arrays_fit && a->size() == n;
  }
  if (n == 0 || msg.nbodies > kMaxCompareBodies || !arrays_fit || msg.regime.size() != n) {
    ++bodies_dropped_;
    Log()->warn("{}: nbodies {} outside 1..{}, or arrays of another length: dropped", msg.name, msg.nbodies,
                kMaxCompareBodies);
    return;
  }
  // Body 0 is a single block's state: the comparison with RL_THETA (the
  // bottom body's) goes on as before, to the same bytes.
  common::BodyOf(msg, 0, body0_);
  HandleModel(body0_);
  if (n < 2) return;

  BodiesVariant& v = BodiesVariantFor(msg);
  BodiesModelSample sample;
  sample.utime = msg.utime;
  sample.n = msg.nbodies;
  for (std::size_t k = 0; k < n; ++k) sample.theta[k] = msg.theta[k];
  if (msg.mode.size() <= sample.mode.size()) {
    sample.mode_length = static_cast<int>(msg.mode.size());
    for (std::size_t k = 0; k < msg.mode.size(); ++k) sample.mode[k] = msg.mode[k];
  }
  if (!bodies_measured_ || bodies_measured_->empty() || msg.utime > bodies_measured_->back().utime) {
    if (!v.pending.push_back(sample)) ++v.unmatched_model;
    return;
  }
  // The measured sample of the same utime, by binary search (utime increasing).
  const common::Ring<BodiesMeasured>& ring = *bodies_measured_;
  std::size_t lo = 0, hi = ring.size();
  while (lo < hi) {
    const std::size_t mid = (lo + hi) / 2;
    if (ring[mid].utime < msg.utime) {
      lo = mid + 1;
    } else {
      hi = mid;
    }
  }
  if (lo < ring.size() && ring[lo].utime == msg.utime) {
    PairBodies(v, ring[lo], sample);
  } else {
    ++v.unmatched_model;
  }
}

CompareNode::BodiesVariant& CompareNode::BodiesVariantFor(const rocklab::model_state4_t& msg) {
  auto it = bodies_variants_.find(msg.name);
  if (it != bodies_variants_.end()) return *it->second;
  auto v = std::make_unique<BodiesVariant>(config_, msg);
  BodiesVariant& ref = *v;
  bodies_order_.push_back(&ref);
  bodies_variants_.emplace(msg.name, std::move(v));
  Log()->info("comparing the {} bodies of variant '{}' with {}BODIES", msg.nbodies, msg.name,
              config_.channel_prefix);
  return ref;
}

void CompareNode::HandleBodies(const rocklab::block_state2_t& msg) {
  const std::size_t n = msg.nbodies > 0 ? static_cast<std::size_t>(msg.nbodies) : 0;
  if (n == 0 || msg.nbodies > kMaxCompareBodies || msg.theta.size() != n || msg.flags.size() != n) {
    ++bodies_dropped_;
    Log()->warn("{}BODIES: nbodies {} outside 1..{}, or arrays of another length: dropped",
                config_.channel_prefix, msg.nbodies, kMaxCompareBodies);
    return;
  }
  bodies_seq_.Add(msg.seq);
  if (!bodies_measured_) {
    bodies_measured_ = std::make_unique<common::Ring<BodiesMeasured>>(config_.align_capacity);
  }
  common::Ring<BodiesMeasured>& ring = *bodies_measured_;
  if (!ring.empty() && msg.utime <= ring.back().utime) {
    ++bodies_dropped_;  // a duplicate or a replay restart, as RL_THETA's
    return;
  }
  ++bodies_count_;
  newest_utime_ = std::max(newest_utime_, msg.utime);
  BodiesMeasured m;
  m.utime = msg.utime;
  m.n = msg.nbodies;
  for (std::size_t k = 0; k < n; ++k) {
    m.theta[k] = msg.theta[k];
    m.valid[k] = (msg.flags[k] & config_.invalid_flags) == 0 && std::isfinite(msg.theta[k]);
  }
  ring.push_back(m);
  for (BodiesVariant* v : bodies_order_) {
    while (!v->pending.empty() && v->pending.front().utime <= msg.utime) {
      const BodiesModelSample waiting = v->pending.front();
      v->pending.pop_front();
      if (waiting.utime == msg.utime) {
        PairBodies(*v, m, waiting);
      } else {
        ++v->unmatched_model;
      }
    }
  }
}

void CompareNode::PairBodies(BodiesVariant& v, const BodiesMeasured& measured,
                             const BodiesModelSample& modelled) {
  if (measured.n != v.n || modelled.n != v.n) {
    ++v.unmatched_model;  // another assembly than the variant's first message, or the rig's
    return;
  }
  ++v.pairs;
  v.mode.assign(modelled.mode.data(), static_cast<std::size_t>(modelled.mode_length));
  v.comparator.Add(measured.utime, measured.theta.data(), measured.valid.data(), modelled.theta.data(),
                   v.mode);
  v.dirty = true;
  if (PublishDue(measured.utime, v.last_pub_utime)) PublishBodies(v);
}

void CompareNode::PublishBodies(BodiesVariant& v) {
  const ComparisonMetrics& first = v.comparator.body(0);
  v.last_pub_utime = first.utime;
  v.dirty = false;
  rocklab::comparison3_t out;
  out.utime = first.utime;
  out.seq = v.compare_seq++;
  out.name = v.name;
  out.nbodies = v.n;
  const auto n = static_cast<std::size_t>(v.n);
  for (auto* a : {&out.error, &out.rms_window, &out.rms_total, &out.nrms, &out.peak_error,
                  &out.impact_timing_error, &out.correlation}) {
    a->resize(n);
  }
  out.valid.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    const ComparisonMetrics& m = v.comparator.body(static_cast<int>(k));
    out.error[k] = m.error;
    out.rms_window[k] = m.rms_window;
    out.rms_total[k] = m.rms_total;
    out.nrms[k] = m.nrms;
    out.peak_error[k] = m.peak_error;
    out.impact_timing_error[k] = m.impact_timing_error;
    out.correlation[k] = m.correlation;
    out.valid[k] = m.valid;
  }
  out.window_s = config_.comparator.window_s;
  out.samples = first.samples;
  const ModeAgreement& mode = v.comparator.mode();
  out.mode_model = mode.model;
  out.mode_measured = mode.measured;
  out.mode_rest_rad = mode.rest_rad;
  out.mode_agreement = mode.fraction();
  out.mode_samples = mode.samples;
  bus_.Publish(v.channel, out);
  ++published_;
}

void CompareNode::Pair(Variant& v, std::int64_t utime, double measured, bool valid,
                       double modelled) {
  ++v.pairs;
  v.comparator.Add(utime, measured, modelled, valid);
  v.dirty = true;
  if (PublishDue(utime, v.last_pub_utime)) PublishCompare(v);
}

void CompareNode::PublishCompare(Variant& v) {
  const ComparisonMetrics& m = v.comparator.metrics();
  v.last_pub_utime = m.utime;
  v.dirty = false;
  rocklab::comparison2_t out;
  out.utime = m.utime;
  out.seq = v.compare_seq++;
  out.name = v.name;
  out.error = m.error;
  out.rms_window = m.rms_window;
  out.window_s = config_.comparator.window_s;
  out.rms_total = m.rms_total;
  out.nrms = m.nrms;
  out.peak_error = m.peak_error;
  out.impact_timing_error = m.impact_timing_error;
  out.correlation = m.correlation;
  out.valid = m.valid;
  out.samples = m.samples;
  bus_.Publish(v.channel, out);
  ++published_;
}

void CompareNode::PublishEvent(std::int8_t kind, const std::string& source, double value,
                               const std::string& detail) {
  Log()->log(kind == rocklab::event_t::RECOVERED ? spdlog::level::info : spdlog::level::warn,
             "{}: {}", source, detail);
  rocklab::event2_t ev;
  ev.utime = newest_utime_;
  ev.seq = event_seq_++;
  ev.sender = "compare";
  ev.source = source;
  ev.kind = kind;
  ev.value = value;
  ev.detail = detail;
  bus_.Publish(config_.channel_prefix + "EVENT", ev);
}

void CompareNode::PublishHealth(const char* state) {
  rocklab::health2_t h{};
  h.utime = newest_utime_;
  h.seq = health_seq_++;
  h.sender = "compare";
  h.node = "compare";
  h.state = state;
  h.count_in = theta_count_ + model_count_ + bodies_count_;
  h.count_out = published_;
  std::int64_t dropped = theta_out_of_order_;
  for (const Variant* v : order_) dropped += v->unmatched_model;
  for (const Band* b : band_order_) dropped += b->unmatched_model;
  for (const BodiesVariant* v : bodies_order_) dropped += v->unmatched_model;
  dropped += bodies_dropped_;
  h.dropped = dropped + bus_.decode_error_count();  // and messages that did not decode
  h.gaps = common::SeqGaps::SaturatingAdd(
      common::SeqGaps::SaturatingAdd(theta_seq_.missing(), model_gaps_), bodies_seq_.missing());
  h.lag_s = std::nan("");  // sample clock and host clock are unrelated offline
  bus_.Publish(config_.channel_prefix + "HEALTH", h);
}

void CompareNode::CheckStale() {
  const double now = CompareHostNowS();
  const bool sample = config_.stale_clock == StaleClock::kSample;
  // How long an input has been silent, on the configured clock, s.
  auto silent_s = [&](double last_host_s, std::int64_t last_utime) {
    if (!sample) return now - last_host_s;
    if (last_utime == INT64_MIN) return 0.0;
    return static_cast<double>(newest_utime_ - last_utime) * 1e-6;
  };
  const double theta_silent = silent_s(last_theta_host_s_, last_theta_utime_);
  if (theta_count_ > 0 && !theta_stale_ && theta_silent > config_.stale_after_s) {
    theta_stale_ = true;
    PublishEvent(rocklab::event_t::STALE, "daq", theta_silent,
                 "no RL_THETA for " + std::to_string(theta_silent) + " s");
  }
  for (Variant* v : order_) {
    const double silent = silent_s(v->last_host_s, v->last_utime);
    if (!v->stale && silent > config_.stale_after_s) {
      v->stale = true;
      PublishEvent(rocklab::event_t::STALE, v->name, silent,
                   "no " + config_.channel_prefix + "MODEL_" + v->name + " for " +
                       std::to_string(silent) + " s");
    }
  }
  if (now - last_health_host_s_ >= config_.health_period_s) {
    last_health_host_s_ = now;
    bool any_stale = theta_stale_;
    for (const Variant* v : order_) any_stale = any_stale || v->stale;
    PublishHealth(any_stale ? "stale" : "running");
  }
}

void CompareNode::Run(const std::atomic<bool>& stop) {
  PublishHealth("running");
  common::RunNodeLoop(bus_, stop, [this] { CheckStale(); }, 2 * config_.subscriber_queue, "compare");
  Finish();
}

void CompareNode::Finish() {
  for (Variant* v : order_) {
    if (v->dirty) PublishCompare(*v);
  }
  for (BodiesVariant* v : bodies_order_) {
    if (v->dirty) PublishBodies(*v);
  }
  for (Band* b : band_order_) {
    // The crossings still waiting for later member impacts: none will come.
    const std::int64_t resolved = b->comparator.metrics().matched_crossings +
                                  b->comparator.metrics().unmatched_crossings;
    b->comparator.Finish();
    const BandMetrics& m = b->comparator.metrics();
    if (b->dirty || m.matched_crossings + m.unmatched_crossings != resolved) PublishCoverage(*b);
  }
  PublishHealth("stopped");
}

std::vector<VariantSummary> CompareNode::Summary() const {
  std::vector<VariantSummary> out;
  for (const Variant* v : order_) {
    VariantSummary s;
    s.name = v->name;
    s.model = v->model;
    s.alpha = v->alpha;
    s.p = v->p;
    s.mu = v->mu;
    s.metrics = v->comparator.metrics();
    s.unmatched_measured = theta_count_ - v->pairs;
    s.unmatched_model = v->unmatched_model + static_cast<std::int64_t>(v->pending.size());
    const auto bodies = bodies_variants_.find(v->name);
    if (bodies != bodies_variants_.end()) {
      const BodiesVariant& b = *bodies->second;
      for (int k = 0; k < b.n; ++k) s.bodies.push_back(b.comparator.body(k));
      s.mode = b.comparator.mode();
      s.bodies_unmatched_measured = bodies_count_ - b.pairs;
      s.bodies_unmatched_model = b.unmatched_model + static_cast<std::int64_t>(b.pending.size());
    }
    out.push_back(s);
  }
  return out;
}

std::vector<BandSummary> CompareNode::BandSummaries() const {
  std::vector<BandSummary> out;
  for (const Band* b : band_order_) {
    BandSummary s;
    s.name = b->name;
    s.model = b->model;
    s.draws = b->draws;
    s.members = b->members;
    s.metrics = b->comparator.metrics();
    s.unmatched_measured = theta_count_ - b->pairs;
    s.unmatched_model = b->unmatched_model + static_cast<std::int64_t>(b->pending.size());
    out.push_back(s);
  }
  return out;
}

void CompareNode::PrintBandSummary(const std::vector<BandSummary>& bands, std::FILE* out) {
  if (bands.empty()) return;
  std::fprintf(out, "%-20s %-8s %7s %9s %9s %9s %9s %9s\n", "band", "model", "members", "cover95%",
               "cover68%", "width_deg", "z_rms", "crossings");
  auto cell = [](double v, double scale) {
    if (std::isnan(v)) return std::string("-");
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.3f", v * scale);
    return std::string(buf);
  };
  for (const BandSummary& s : bands) {
    const BandMetrics& m = s.metrics;
    std::fprintf(out, "%-20s %-8s %3d/%-3d %9s %9s %9s %9s %4lld/%-4lld\n", s.name.c_str(), s.model.c_str(),
                 s.members, s.draws, cell(m.coverage95_total, 100).c_str(),
                 cell(m.coverage68_total, 100).c_str(), cell(m.width95, common::kDegPerRad).c_str(),
                 cell(m.impact_timing_z_rms, 1).c_str(), static_cast<long long>(m.matched_crossings),
                 static_cast<long long>(m.matched_crossings + m.unmatched_crossings));
  }
}

void CompareNode::PrintSummary(const std::vector<VariantSummary>& summary, std::FILE* out) {
  std::fprintf(out, "%-20s %-8s %8s %8s %6s %11s %9s %7s %9s %11s %11s %7s\n", "variant", "model",
               "alpha", "p", "mu", "rms_deg", "max_deg", "nrms", "corr", "timing_s",
               "peak_deg", "valid%");
  constexpr double kDeg = common::kDegPerRad;
  // A metric that has no value (no crossing matched) is "-", never a number.
  auto cell = [](double v) {
    if (std::isnan(v)) return std::string("-");
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.5f", v);
    return std::string(buf);
  };
  for (const VariantSummary& s : summary) {
    const ComparisonMetrics& m = s.metrics;
    const double valid_pct =
        m.samples > 0 ? 100.0 * static_cast<double>(m.valid_samples) / m.samples : 0.0;
    std::fprintf(out, "%-20s %-8s %8.4f %8.4f %6.3f %11.5f %9.4f %7.4f %9.5f %11s %11s %7.2f\n",
                 s.name.c_str(), s.model.c_str(), s.alpha, s.p, s.mu, m.rms_total * kDeg,
                 m.max_abs_error * kDeg, m.nrms, m.correlation, cell(m.mean_abs_timing_error).c_str(),
                 cell(m.mean_abs_peak_error * kDeg).c_str(), valid_pct);
  }
  // An assembly's bodies (bottom-up, body 0 is the row above) and its modes.
  for (const VariantSummary& s : summary) {
    for (std::size_t k = 0; k < s.bodies.size(); ++k) {
      const ComparisonMetrics& m = s.bodies[k];
      const double valid_pct =
          m.samples > 0 ? 100.0 * static_cast<double>(m.valid_samples) / m.samples : 0.0;
      std::fprintf(out, "%-20s body %-3zu %25s %11.5f %9.4f %7.4f %9.5f %11s %11s %7.2f\n",
                   s.name.c_str(), k, "", m.rms_total * kDeg, m.max_abs_error * kDeg, m.nrms,
                   m.correlation, cell(m.mean_abs_timing_error).c_str(),
                   cell(m.mean_abs_peak_error * kDeg).c_str(), valid_pct);
    }
    if (!s.bodies.empty()) {
      std::fprintf(out, "%s: modes agree %s of %lld samples (rest below %.4f rad)\n", s.name.c_str(),
                   s.mode.samples > 0 ? (cell(100.0 * s.mode.fraction()) + " %").c_str() : "-",
                   static_cast<long long>(s.mode.samples), s.mode.rest_rad);
    }
  }
  for (const VariantSummary& s : summary) {
    if (s.metrics.matched_crossings > 0) continue;
    std::fprintf(out,
                 "%s: no zero crossing matched (%lld unmatched): no timing or peak error "
                 "(\"-\" above, null in the JSON summary)\n",
                 s.name.c_str(), static_cast<long long>(s.metrics.unmatched_crossings));
  }
}

void CompareNode::WriteSummaryJson(const std::vector<VariantSummary>& summary,
                                   const std::string& path) {
  WriteSummaryJson(summary, {}, path);
}

std::string CompareNode::SummaryJsonText(const std::vector<VariantSummary>& summary,
                                         const std::vector<BandSummary>& bands) {
  // A variant's figures and each of an assembly's bodies' (the same keys).
  auto figures = [](const ComparisonMetrics& m) {
    return nlohmann::json{{"samples", m.samples},
                          {"valid_samples", m.valid_samples},
                          {"rms", m.rms_total},
                          {"nrms", m.nrms},
                          {"max_abs_error", m.max_abs_error},
                          {"peak_measured", m.peak_measured},
                          {"correlation", m.correlation},
                          {"matched_crossings", m.matched_crossings},
                          {"unmatched_crossings", m.unmatched_crossings},
                          {"mean_abs_timing_error", OrNull(m.mean_abs_timing_error)},
                          {"mean_abs_peak_error", OrNull(m.mean_abs_peak_error)}};
  };
  nlohmann::json variants = nlohmann::json::array();
  for (const VariantSummary& s : summary) {
    nlohmann::json v = figures(s.metrics);
    v["name"] = s.name;
    v["model"] = s.model;
    v["alpha"] = s.alpha;
    v["p"] = s.p;
    v["mu"] = s.mu;
    v["unmatched_measured"] = s.unmatched_measured;
    v["unmatched_model"] = s.unmatched_model;
    // An assembly only: a single block's variant keeps its keys.
    if (!s.bodies.empty()) {
      nlohmann::json bodies = nlohmann::json::array();
      for (std::size_t k = 0; k < s.bodies.size(); ++k) {
        nlohmann::json b = figures(s.bodies[k]);
        b["body"] = k;        // the index, 0 on the table (LCM arrays, export's _k columns)
        b["number"] = k + 1;  // the K of simulate's and reconstruct's CSV columns theta_K
        bodies.push_back(b);
      }
      v["bodies"] = bodies;
      v["mode_agreement"] = OrNull(s.mode.fraction());
      v["mode_samples"] = s.mode.samples;
      v["mode_rest_rad"] = s.mode.rest_rad;
      v["bodies_unmatched_measured"] = s.bodies_unmatched_measured;
      v["bodies_unmatched_model"] = s.bodies_unmatched_model;
    }
    variants.push_back(v);
  }
  nlohmann::json band_list = nlohmann::json::array();
  for (const BandSummary& s : bands) {
    const BandMetrics& m = s.metrics;
    band_list.push_back({{"name", s.name},
                         {"model", s.model},
                         {"draws", s.draws},
                         {"members", s.members},
                         {"samples", m.samples},
                         {"valid_samples", m.valid_samples},
                         {"band_coverage_95", OrNull(m.coverage95_total)},
                         {"band_coverage_68", OrNull(m.coverage68_total)},
                         {"impact_timing_z_rms", OrNull(m.impact_timing_z_rms)},
                         {"impact_timing_z_max_abs", OrNull(m.impact_timing_z_max_abs)},
                         {"matched_crossings", m.matched_crossings},
                         {"unmatched_crossings", m.unmatched_crossings},
                         {"unmatched_measured", s.unmatched_measured},
                         {"unmatched_model", s.unmatched_model}});
  }
  nlohmann::json doc = {
      {"variants", variants},
      {"bands", band_list},
      {"units",
       {{"alpha", "rad"}, {"p", "rad/s"}, {"mu", "1"}, {"rms", "rad"}, {"nrms", "1"},
        {"max_abs_error", "rad"}, {"peak_measured", "rad"}, {"correlation", "1"},
        {"mean_abs_timing_error", "s"}, {"mean_abs_peak_error", "rad"},
        {"band_coverage_95", "1"}, {"band_coverage_68", "1"}, {"impact_timing_z_rms", "1"},
        {"impact_timing_z_max_abs", "1"}}}};
  // The units of an assembly's keys, only when one is there (a single
  // block's document is unchanged).
  bool any_bodies = false;
  for (const VariantSummary& s : summary) any_bodies = any_bodies || !s.bodies.empty();
  if (any_bodies) {
    doc["units"]["mode_agreement"] = "1";
    doc["units"]["mode_rest_rad"] = "rad";
  }
  return doc.dump(2) + "\n";
}

void CompareNode::WriteSummaryJson(const std::vector<VariantSummary>& summary,
                                   const std::vector<BandSummary>& bands, const std::string& path) {
  try {
    common::WriteFileAtomically(path, SummaryJsonText(summary, bands));
  } catch (const std::runtime_error& e) {
    throw std::runtime_error(std::string("summary: ") + e.what());
  }
}

}  // namespace rocklab::compare
