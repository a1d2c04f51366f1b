#include "common/model_state.h"

#include "common/wire.h"

namespace rocklab::common {

void ToModelState2(const rocklab::model_state_t& in, rocklab::model_state2_t& out) {
  out.utime = in.utime;
  out.name = in.name;
  out.model = in.model;
  out.theta = in.theta;
  out.theta_dot = in.theta_dot;
  out.chi = in.chi;
  out.psi = in.psi;
  out.energy = in.energy;
  out.impact_count = in.impact_count;
  out.regime = in.regime;
  out.alpha = in.alpha;
  out.p = in.p;
  out.mu = in.mu;
  out.l = in.l;
  out.equations = rocklab::model_state2_t::EQUATIONS_UNKNOWN;
}

const char* DecodeModelState(const void* data, int size, rocklab::model_state2_t& out,
                             rocklab::model_state_t& scratch) {
  if (WireFingerprint(data, size) == static_cast<std::int64_t>(rocklab::model_state_t::getHash())) {
    if (const char* why = GuardedDecode(data, size, scratch)) return why;
    ToModelState2(scratch, out);
    return nullptr;
  }
  if (WireFingerprint(data, size) == static_cast<std::int64_t>(rocklab::model_state3_t::getHash())) {
    // What the model node publishes now: read without its seq.
    thread_local rocklab::model_state3_t s3;
    if (const char* why = GuardedDecode(data, size, s3)) return why;
    out.utime = s3.utime;
    out.name = s3.name;
    out.model = s3.model;
    out.theta = s3.theta;
    out.theta_dot = s3.theta_dot;
    out.chi = s3.chi;
    out.psi = s3.psi;
    out.energy = s3.energy;
    out.impact_count = s3.impact_count;
    out.regime = s3.regime;
    out.alpha = s3.alpha;
    out.p = s3.p;
    out.mu = s3.mu;
    out.l = s3.l;
    out.equations = s3.equations;
    return nullptr;
  }
  return GuardedDecode(data, size, out);
}

Subscription SubscribeModelState(
    Bus& bus, const std::string& channel_regex,
    std::function<void(const std::string&, const rocklab::model_state2_t&)> handler,
    int queue_capacity) {
  return bus.SubscribeDecoded<rocklab::model_state2_t>(
      channel_regex,
      [scratch = rocklab::model_state_t{}](const void* data, int size,
                                           rocklab::model_state2_t& msg) mutable {
        return DecodeModelState(data, size, msg, scratch);
      },
      std::move(handler), queue_capacity);
}

}  // namespace rocklab::common
