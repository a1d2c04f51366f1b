// LiveState: one LCM message into the state (decoded with the reused
// buffers, bounded, counted).
#include "monitor/live_state_impl.h"

#include "common/wire.h"

namespace rocklab::monitor {

using namespace live_detail;  // NOLINT(google-build-using-namespace): the private helpers of live_state_impl.h

bool LiveState::Impl::Ingest(std::string_view channel, const void* data, int size) {
  ++seq;
  ChannelCount* count = CountFor(channel);
  if (count) ++count->messages;
  if (!StartsWith(channel, options.channel_prefix)) return false;
  const std::string_view kind = channel.substr(options.channel_prefix.size());
  bool known = true;
  const bool ok = Dispatch(kind, data, size, known);
  if (known && !ok && count) ++count->decode_errors;
  std::int64_t message_seq = 0;
  std::string_view sender;
  // Every current rocklab type numbers its messages (also on channels not
  // shown, e.g. RL_RAW). A message refused after it decoded (an unusable
  // time) still arrived: its number counts, so the next is not a gap.
  if (count && common::WireSeq(data, size, message_seq, sender)) {
    count->seq.Add(sender, message_seq);
  }
  if (hold_current) {
    hold_current = false;
    const auto* bytes = static_cast<const std::uint8_t*>(data);
    held.push_back({std::string(channel), std::vector<std::uint8_t>(bytes, bytes + size)});
  }
  if (jump_ready) {
    jump_ready = false;
    AcceptClockJump();
  }
  return known && ok;
}

void LiveState::Impl::AcceptClockJump() {
  std::vector<Held> pending;
  pending.swap(held);
  candidate_count = 0;
  if (candidate_new_test || candidate_first < latest_utime || samples_on_clock < kAgreeingSamples) {
    // The clock went back, or was set by fewer samples than agree now: those
    // were wild (a stray datagram before the test), counted as such.
    if (samples_on_clock < kAgreeingSamples) dropped_far_from_clock += samples_on_clock;
    NewRecord();
  } else {
    latest_utime = candidate_first;  // a forward gap in the same record
  }
  for (const Held& h : pending) {
    ++seq;
    bool known = true;
    Dispatch(std::string_view(h.channel).substr(options.channel_prefix.size()), h.bytes.data(),
             static_cast<int>(h.bytes.size()), known);
    if (hold_current) {  // far even from its fellows' clock (they spread over more than the limit)
      hold_current = false;
      ++dropped_far_from_clock;
    }
  }
  jump_ready = false;
  DropCandidate();
}

bool LiveState::Impl::Dispatch(std::string_view kind, const void* data, int size, bool& known) {
  bool ok = false;
  try {
    if (kind == "THETA") {
      ok = IngestTheta(data, size);
    } else if (kind == "TABLE") {
      ok = IngestTable(data, size);
    } else if (StartsWith(kind, "MODEL_") && kind.size() > 6) {
      ok = IngestModel(kind.substr(6), data, size);
    } else if (StartsWith(kind, "COMPARE_") && kind.size() > 8) {
      ok = IngestCompare(kind.substr(8), data, size);
    } else if (kind == "BODIES") {
      ok = IngestBodies(data, size);
    } else if (StartsWith(kind, "COMPAREBODIES_") && kind.size() > 14) {
      ok = IngestCompareBodies(kind.substr(14), data, size);
    } else if (StartsWith(kind, "BAND_") && kind.size() > 5) {
      ok = IngestBand(kind.substr(5), data, size);
    } else if (StartsWith(kind, "COVERAGE_") && kind.size() > 9) {
      ok = IngestCoverage(kind.substr(9), data, size);
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
  return ok;
}

bool LiveState::Impl::IngestTheta(const void* data, int size) {
  if (!DecodeSample(theta_msg, data, size)) return false;
  if (!SeeSampleClock(theta_msg.utime)) return true;  // held
  const rocklab::block_state_t& m = theta_msg;
  AddPoint(measured, m.utime, m.theta * kDegPerRad, 0.0);
  if (InWindow(m.utime) && std::isfinite(m.theta)) {
    measured_peak_abs_theta = std::fmax(measured_peak_abs_theta, std::fabs(m.theta));
  }
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

bool LiveState::Impl::IngestTable(const void* data, int size) {
  if (!DecodeSample(table_msg, data, size)) return false;
  if (!SeeSampleClock(table_msg.utime)) return true;  // held
  const rocklab::table_state_t& m = table_msg;
  AddPoint(table, m.utime, m.acceleration, m.displacement);
  if (InWindow(m.utime)) {
    ++table_samples;
    if (std::isfinite(m.acceleration)) table_peak_accel = std::fmax(table_peak_accel, std::fabs(m.acceleration));
    if (std::isfinite(m.displacement)) table_peak_disp = std::fmax(table_peak_disp, std::fabs(m.displacement));
  }
  return true;
}

bool LiveState::Impl::IngestModel(std::string_view name, const void* data, int size) {
  // model_state4_t (an assembly), model_state3_t, or model_state2_t /
  // model_state_t from a log written before it, as model_state4_t; body 0
  // (the bottom body, RL_THETA's) is the variant's theta as a single block's.
  if (model_decoder(data, size, model4_msg) != nullptr || model4_msg.nbodies < 1 ||
      !UsableUtime(model4_msg.utime)) {
    return false;
  }
  if (!SeeSampleClock(model4_msg.utime)) return true;  // held
  Variant* v = VariantFor(name);
  if (!v) return true;  // counted in dropped.variants
  common::BodyOf(model4_msg, 0, model_msg);
  v->has_params = true;
  v->params = model_msg;  // copies reuse the strings' capacity
  AddPoint(v->theta, model_msg.utime, model_msg.theta * kDegPerRad, 0.0);
  if (InWindow(model_msg.utime) && std::isfinite(model_msg.theta)) {
    v->peak_abs_theta = std::fmax(v->peak_abs_theta, std::fabs(model_msg.theta));
  }
  if (model4_msg.nbodies >= 2) {
    for (std::size_t k = 0; k < static_cast<std::size_t>(model4_msg.nbodies); ++k) {
      if (Series* s = BodySeries(v->bodies, k)) AddPoint(*s, model4_msg.utime, model4_msg.theta[k] * kDegPerRad, 0.0);
    }
  }
  return true;
}

LiveState::Impl::Series* LiveState::Impl::BodySeries(std::vector<std::unique_ptr<Series>>& list,
                                                     std::size_t k) {
  if (k >= kMaxBodies) {
    ++dropped_bodies;
    return nullptr;
  }
  while (list.size() <= k) list.push_back(std::make_unique<Series>(capacity, grows, options.max_points));
  return list[k].get();
}

bool LiveState::Impl::IngestBodies(const void* data, int size) {
  if (!DecodeSample(bodies_msg, data, size) || bodies_msg.nbodies < 1) return false;
  if (!SeeSampleClock(bodies_msg.utime)) return true;  // held
  for (std::size_t k = 0; k < static_cast<std::size_t>(bodies_msg.nbodies); ++k) {
    if (Series* s = BodySeries(measured_bodies, k)) AddPoint(*s, bodies_msg.utime, bodies_msg.theta[k] * kDegPerRad, 0.0);
  }
  return true;
}

bool LiveState::Impl::IngestCompareBodies(std::string_view name, const void* data, int size) {
  if (!DecodeSample(compare_bodies_msg, data, size)) return false;
  if (!SeeSampleClock(compare_bodies_msg.utime)) return true;  // held
  Variant* v = VariantFor(name);
  if (!v) return true;
  if (T(compare_bodies_msg.utime) <= options.to_s) {  // the newest inside the window
    v->has_bodies_latest = true;
    v->bodies_latest = compare_bodies_msg;
    for (std::string* text : {&v->bodies_latest.name, &v->bodies_latest.mode_model, &v->bodies_latest.mode_measured}) {
      text->resize(std::min(text->size(), kMaxTextBytes));  // a message's text cannot grow the state
    }
  }
  return true;
}

bool LiveState::Impl::IngestCompare(std::string_view name, const void* data, int size) {
  if (compare_decoder(data, size, compare_msg) != nullptr || !UsableUtime(compare_msg.utime)) return false;
  if (!SeeSampleClock(compare_msg.utime)) return true;  // held
  Variant* v = VariantFor(name);
  if (!v) return true;
  const rocklab::comparison2_t& m = compare_msg;
  AddPoint(v->comparison, m.utime, m.error * kDegPerRad, m.rms_window * kDegPerRad);
  // A matched crossing's timing error is carried until the next one: count
  // each once, when the carried value changes.
  const double timing = m.impact_timing_error;
  if (InWindow(m.utime) && std::isfinite(timing) &&
      !(timing == v->timing_last)) {
    ++v->timing_count;
    v->timing_sum_sq += timing * timing;
  }
  v->timing_last = timing;
  if (T(m.utime) <= options.to_s) {  // the newest comparison inside the window
    v->has_latest = true;
    v->latest = m;
  }
  return true;
}

bool LiveState::Impl::IngestBand(std::string_view name, const void* data, int size) {
  if (!DecodeSample(band_msg, data, size)) return false;
  if (!SeeSampleClock(band_msg.utime)) return true;  // held
  Band* b = BandFor(name);
  if (!b) return true;  // counted in dropped.variants
  const rocklab::model_band_t& m = band_msg;
  b->has_params = true;
  AssignText(b->model, m.model);
  b->draws = m.draws;
  b->members = m.members;
  AddPoint(b->median, m.utime, m.theta_median * kDegPerRad, 0.0);
  AddPoint(b->band68, m.utime, m.theta_lo68 * kDegPerRad, m.theta_hi68 * kDegPerRad);
  AddPoint(b->band95, m.utime, m.theta_lo95 * kDegPerRad, m.theta_hi95 * kDegPerRad);
  return true;
}

bool LiveState::Impl::IngestCoverage(std::string_view name, const void* data, int size) {
  if (!DecodeSample(coverage_msg, data, size)) return false;
  if (!SeeSampleClock(coverage_msg.utime)) return true;  // held
  Band* b = BandFor(name);
  if (!b) return true;
  if (T(coverage_msg.utime) <= options.to_s) {  // the newest inside the window
    b->has_latest = true;
    b->latest = coverage_msg;
  }
  return true;
}

bool LiveState::Impl::IngestEvent(const void* data, int size) {
  if (event_decoder(data, size, event_msg) != nullptr || !UsableUtime(event_msg.utime)) return false;
  const rocklab::event2_t& m = event_msg;
  if (!has_clock) {
    has_clock = true;
    t0_utime = latest_utime = m.utime;
  }
  // An event does not move the clock (the samples do): a wild one cannot
  // make the test's samples look far from it.
  // Filled in place, then copied into the ring's slot: the copy reuses the
  // slot's string capacity once the ring has gone round.
  Event& e = event_scratch;
  e.seq = seq;
  e.utime = m.utime;
  AssignText(e.source, m.source);
  e.kind = m.kind;
  e.value = m.value;
  AssignText(e.detail, m.detail);
  if (InWindow(m.utime)) {
    PushGrowing(events, e, grows, options.max_events, dropped_events);
  } else {
    ++outside_window;
  }

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
  if (health_decoder(data, size, health_msg) != nullptr) return false;
  auto it = health.find(health_msg.node);
  if (it == health.end()) {
    if (health.size() >= options.max_nodes) {
      ++dropped_nodes;
      return true;
    }
    it = health.emplace(health_msg.node, rocklab::health2_t{}).first;
  }
  it->second = health_msg;
  return true;
}

bool LiveState::Impl::IngestConfig(const void* data, int size) {
  if (config_decoder(data, size, config_msg) != nullptr) return false;
  // A configuration on a clock far from the page's: the DAQ started a new
  // test, so the next sample that agrees with it is taken as the new clock.
  if (has_clock && UsableUtime(config_msg.utime) &&
      std::fabs(static_cast<double>(config_msg.utime) - static_cast<double>(latest_utime)) >
          options.new_record_after_s * 1e6) {
    DropCandidate();
    candidate_first = candidate_latest = config_msg.utime;
    candidate_count = kAgreeingSamples - 1;
    candidate_new_test = true;
  }
  has_config = true;
  AssignText(rig_name, config_msg.rig_name);
  AssignText(calibration_id, config_msg.calibration_id);
  sample_rate_hz = config_msg.sample_rate_hz;
  alpha = config_msg.alpha;
  p = config_msg.p;
  mu = config_msg.mu;
  return true;
}

}  // namespace rocklab::monitor
