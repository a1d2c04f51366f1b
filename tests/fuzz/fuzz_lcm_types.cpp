// Fuzz target: the decode of every rocklab type as the nodes receive it,
// through the Bus's typed path (common::Bus::Subscribe: the wire pre-check,
// then lcm-gen's decode) on a DirectBus, and the channels whose type has a
// successor through common::SubscribeVersioned (the current type or an
// older one; the per-body block_state2_t and model_state4_t with every
// older type they read), and common::WireSeq on every payload. Input: the first byte
// picks the channel (and so the type), the rest is the payload; when the
// second byte is odd the payload starts with that type's fingerprint, so
// the fuzzer reaches the fields at once.
// Invariants: nothing escapes the bus; each message is either handled or
// counted as a decode error (never both, never neither); no handler error; a
// handled message re-encodes to bytes the pre-check accepts and that decode
// to the same encoding (so what reached a node is well formed); no large
// allocation (libFuzzer's -malloc_limit_mb, the default = -rss_limit_mb).
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "common/bus.h"
#include "common/direct_bus.h"
#include "common/versions.h"
#include "common/wire.h"
#include "rocklab/block_state2_t.hpp"
#include "rocklab/block_state_t.hpp"
#include "rocklab/raw_frame_t.hpp"
#include "rocklab/table_state_t.hpp"
#include "tests/fuzz/fuzz_util.h"

namespace {

using rocklab::common::DirectBus;
using rocklab::fuzz::Violated;

std::int64_t handled = 0;

// Re-encodes `m` and checks the bytes pass the pre-check and decode back
// to the same encoding.
template <class Msg>
void CheckHandled(const Msg& m) {
  ++handled;
  const int size = m.getEncodedSize();
  if (size < 8) Violated("encoded size");
  std::vector<std::uint8_t> b(static_cast<std::size_t>(size));
  if (m.encode(b.data(), 0, size) != size) Violated("re-encode");
  int consumed = -1;
  if (const char* why = rocklab::common::WireCheck(rocklab::common::WireLayoutOf<Msg>(), b.data(), size, &consumed)) {
    Violated("a handled message re-encodes to bytes the pre-check refuses", why);
  }
  if (consumed != size) Violated("walk length differs from the encoded size");
  Msg again{};
  if (rocklab::common::GuardedDecode(b.data(), size, again) != nullptr) Violated("re-decode");
  std::vector<std::uint8_t> b2(static_cast<std::size_t>(again.getEncodedSize()));
  again.encode(b2.data(), 0, static_cast<int>(b2.size()));
  // NaN payloads re-encode bit for bit: compare bytes, not values.
  if (b2 != b) Violated("decode(encode(m)) differs");
}

struct Nodes {
  DirectBus bus;
  std::vector<rocklab::common::Subscription> subscriptions;
  Nodes() {
    Sub<rocklab::raw_frame_t>("RL_RAW");
    Versioned<rocklab::common::DaqConfigDecoder>("RL_DAQ_CONFIG");
    Sub<rocklab::table_state_t>("RL_TABLE");
    Sub<rocklab::block_state_t>("RL_THETA");
    Versioned<rocklab::common::ComparisonDecoder>("RL_COMPARE_.*");
    Versioned<rocklab::common::EventDecoder>("RL_EVENT");
    Versioned<rocklab::common::HealthDecoder>("RL_HEALTH");
    Versioned<rocklab::common::ModelStateDecoder>("RL_MODEL_.*");
    // The per-body types and every older type they read (no node subscribes
    // them yet: channels of their own).
    Versioned<rocklab::common::BlockStateBodiesDecoder>("RL_BODIES_THETA");
    Versioned<rocklab::common::ModelStateBodiesDecoder>("RL_BODIES_MODEL_.*");
  }
  template <class Msg>
  void Sub(const std::string& channel) {
    subscriptions.push_back(bus.Subscribe<Msg>(channel, [](const std::string&, const Msg& m) { CheckHandled(m); }));
  }
  template <class Decoder>
  void Versioned(const std::string& channel) {
    subscriptions.push_back(rocklab::common::SubscribeVersioned<Decoder>(
        bus, channel, [](const std::string&, const typename Decoder::Message& m) { CheckHandled(m); }));
  }
};

struct Pick {
  const char* channel;
  std::int64_t fingerprint;
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static Nodes nodes;  // subscriptions made once, as a node's are
  if (size < 2) return 0;
  const Pick picks[] = {
      {"RL_RAW", static_cast<std::int64_t>(rocklab::raw_frame_t::getHash())},
      {"RL_DAQ_CONFIG", static_cast<std::int64_t>(rocklab::daq_config_t::getHash())},
      {"RL_DAQ_CONFIG", static_cast<std::int64_t>(rocklab::daq_config2_t::getHash())},
      {"RL_TABLE", static_cast<std::int64_t>(rocklab::table_state_t::getHash())},
      {"RL_THETA", static_cast<std::int64_t>(rocklab::block_state_t::getHash())},
      {"RL_COMPARE_a", static_cast<std::int64_t>(rocklab::comparison_t::getHash())},
      {"RL_COMPARE_a", static_cast<std::int64_t>(rocklab::comparison2_t::getHash())},
      {"RL_EVENT", static_cast<std::int64_t>(rocklab::event_t::getHash())},
      {"RL_EVENT", static_cast<std::int64_t>(rocklab::event2_t::getHash())},
      {"RL_HEALTH", static_cast<std::int64_t>(rocklab::health_t::getHash())},
      {"RL_HEALTH", static_cast<std::int64_t>(rocklab::health2_t::getHash())},
      {"RL_MODEL_a", static_cast<std::int64_t>(rocklab::model_state2_t::getHash())},
      {"RL_MODEL_c", static_cast<std::int64_t>(rocklab::model_state3_t::getHash())},
      {"RL_MODEL_b", static_cast<std::int64_t>(rocklab::model_state_t::getHash())},
      // Appended: the seeds' first bytes keep their picks.
      {"RL_BODIES_THETA", static_cast<std::int64_t>(rocklab::block_state2_t::getHash())},
      {"RL_BODIES_THETA", static_cast<std::int64_t>(rocklab::block_state_t::getHash())},
      {"RL_BODIES_MODEL_a", static_cast<std::int64_t>(rocklab::model_state4_t::getHash())},
      {"RL_BODIES_MODEL_a", static_cast<std::int64_t>(rocklab::model_state3_t::getHash())},
      {"RL_BODIES_MODEL_a", static_cast<std::int64_t>(rocklab::model_state2_t::getHash())},
      {"RL_BODIES_MODEL_a", static_cast<std::int64_t>(rocklab::model_state_t::getHash())},
  };
  const Pick& pick = picks[data[0] % (sizeof picks / sizeof picks[0])];
  std::vector<std::uint8_t> payload;
  if (data[1] & 1) {
    const auto u = static_cast<std::uint64_t>(pick.fingerprint);
    for (int i = 7; i >= 0; --i) payload.push_back(static_cast<std::uint8_t>(u >> (8 * i)));
  }
  payload.insert(payload.end(), data + 2, data + size);

  std::int64_t seq = 0;
  std::string_view sender;
  if (rocklab::common::WireSeq(payload.data(), static_cast<int>(payload.size()), seq, sender) &&
      (sender.data() != nullptr &&
       (sender.data() < reinterpret_cast<const char*>(payload.data()) ||
        sender.data() + sender.size() > reinterpret_cast<const char*>(payload.data() + payload.size())))) {
    Violated("WireSeq's sender lies outside the message");
  }
  const std::int64_t errors_before = nodes.bus.decode_error_count();
  const std::int64_t handled_before = handled;
  nodes.bus.Publish(pick.channel, payload.data(), static_cast<int>(payload.size()));
  const std::int64_t got = (handled - handled_before) + (nodes.bus.decode_error_count() - errors_before);
  if (got != 1) Violated("a message neither handled nor counted, or both");
  if (nodes.bus.handler_error_count() != 0) Violated("a handler error");
  return 0;
}
