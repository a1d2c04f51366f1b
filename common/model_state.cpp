#include "common/model_state.h"

#include "common/versions.h"
#include "common/wire.h"

namespace rocklab::common {

void ToModelState2(const rocklab::model_state_t& in, rocklab::model_state2_t& out) {
  CopyModelStateFields(in, out);
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
    CopyModelStateFields(s3, out);
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
