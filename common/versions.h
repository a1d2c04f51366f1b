#pragma once
/// @file
/// Every rocklab channel's type carries `seq`, its publisher's message number
/// on the channel (0, 1, 2, ...), so whoever receives counts every message
/// lost anywhere on the bus. The types that lacked it got a successor (LCM
/// has no schema evolution: a new field is a new type): comparison2_t,
/// daq_config2_t, event2_t, health2_t, model_state3_t. Nodes publish the
/// successors; consumers also accept the older types (logs written before),
/// told apart by the fingerprint, and read them as the successor with
/// seq = kNoSeq (nothing to count). RL_EVENT and RL_HEALTH have several
/// publishers, each numbering its own messages: their gaps are counted per
/// sender (event2_t.sender, health2_t.sender: unique per process), see
/// ChannelSeqGaps.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <tuple>
#include <utility>
#include <vector>

#include "common/bus.h"
#include "common/field_tables.h"
#include "common/seq_gaps.h"
#include "common/wire.h"
#include "rocklab/block_state2_t.hpp"
#include "rocklab/block_state_t.hpp"
#include "rocklab/comparison2_t.hpp"
#include "rocklab/comparison_t.hpp"
#include "rocklab/daq_config2_t.hpp"
#include "rocklab/daq_config_t.hpp"
#include "rocklab/event2_t.hpp"
#include "rocklab/event_t.hpp"
#include "rocklab/health2_t.hpp"
#include "rocklab/health_t.hpp"
#include "rocklab/model_state2_t.hpp"
#include "rocklab/model_state3_t.hpp"
#include "rocklab/model_state4_t.hpp"
#include "rocklab/model_state_t.hpp"

namespace rocklab::common {

/// `seq` of a message read from an older type, which has none.
inline constexpr std::int64_t kNoSeq = -1;

/// The older type's fields copied into its successor; seq = kNoSeq (and
/// event2_t/health2_t.sender empty, model_state3_t.equations EQUATIONS_UNKNOWN for a
/// model_state_t).
void Upgrade(const rocklab::comparison_t& in, rocklab::comparison2_t& out);
void Upgrade(const rocklab::daq_config_t& in, rocklab::daq_config2_t& out);
void Upgrade(const rocklab::event_t& in, rocklab::event2_t& out);
void Upgrade(const rocklab::health_t& in, rocklab::health2_t& out);
void Upgrade(const rocklab::model_state_t& in, rocklab::model_state3_t& out);
void Upgrade(const rocklab::model_state2_t& in, rocklab::model_state3_t& out);

/// The per-body types (an assembly of rigid bodies, bottom-up): a single
/// block's message read as nbodies = 1, each per-body field holding the
/// old field's value as its only element. model_state4_t.mode is "" (an
/// older type does not say); seq and equations as into model_state3_t.
void Upgrade(const rocklab::block_state_t& in, rocklab::block_state2_t& out);
void Upgrade(const rocklab::model_state3_t& in, rocklab::model_state4_t& out);
void Upgrade(const rocklab::model_state2_t& in, rocklab::model_state4_t& out);
void Upgrade(const rocklab::model_state_t& in, rocklab::model_state4_t& out);

/// Body `k` (0 <= k < in.nbodies) of an assembly's state as a single
/// block's: its theta, theta_dot, chi, psi, regime, alpha, p, mu, and the
/// whole's utime, seq, name, model, energy, impact_count, l, equations.
/// Body 0 of a model_state4_t read from a model_state3_t is that message
/// again. No allocation once `out`'s strings have grown.
void BodyOf(const rocklab::model_state4_t& in, std::size_t k, rocklab::model_state3_t& out);

/// Decodes `Current` or any of `Old` (by the fingerprint) into a `Current`,
/// guarded (GuardedDecode). Holds one scratch message per older type, so no
/// allocation once their strings have grown. Call: nullptr on success,
/// otherwise the reason.
template <class Current, class... Old>
class VersionedDecoder {
 public:
  using Message = Current;
  /// The older types, and how an object of one is read as `Current` (what
  /// decoding its bytes gives): Bus::SubscribeDecodedOrValue hands an
  /// in-process object of one of them to a DirectBus subscription so.
  using OldTypes = std::tuple<Old...>;
  template <class O>
  static void FromOld(const O& in, Current& out) {
    Upgrade(in, out);
  }
  const char* operator()(const void* data, int size, Current& out) {
    const std::int64_t fingerprint = WireFingerprint(data, size);
    const char* why = nullptr;
    if (TryOld<0>(fingerprint, data, size, out, why)) return why;
    return GuardedDecode(data, size, out);
  }

 private:
  template <std::size_t I>
  bool TryOld(std::int64_t fingerprint, const void* data, int size, Current& out, const char*& why) {
    if constexpr (I == sizeof...(Old)) {
      return false;
    } else {
      auto& scratch = std::get<I>(scratch_);
      using T = std::decay_t<decltype(scratch)>;
      if (fingerprint != static_cast<std::int64_t>(T::getHash())) {
        return TryOld<I + 1>(fingerprint, data, size, out, why);
      }
      why = GuardedDecode(data, size, scratch);
      if (why == nullptr) Upgrade(scratch, out);
      return true;
    }
  }
  std::tuple<Old...> scratch_;
};

/// The fields every model_state type has (all but seq, equations and
/// model_state4_t's nbodies and mode), copied between any two of them
/// (into a model_state4_t: each per-body field as its only element).
template <class In, class Out>
void CopyModelStateFields(const In& in, Out& out) {
  FieldCopier<In, Out> copier{in, out};
  ModelStateFields<rocklab::model_state_t>(copier);
}

using ComparisonDecoder = VersionedDecoder<rocklab::comparison2_t, rocklab::comparison_t>;
using DaqConfigDecoder = VersionedDecoder<rocklab::daq_config2_t, rocklab::daq_config_t>;
using EventDecoder = VersionedDecoder<rocklab::event2_t, rocklab::event_t>;
using HealthDecoder = VersionedDecoder<rocklab::health2_t, rocklab::health_t>;
using ModelStateDecoder =
    VersionedDecoder<rocklab::model_state3_t, rocklab::model_state2_t, rocklab::model_state_t>;
/// RL_THETA and RL_MODEL_<name> as the per-body types, whichever type
/// carries them (no node publishes the per-body types yet; the readers
/// take both).
using BlockStateBodiesDecoder = VersionedDecoder<rocklab::block_state2_t, rocklab::block_state_t>;
using ModelStateBodiesDecoder = VersionedDecoder<rocklab::model_state4_t, rocklab::model_state3_t,
                                                 rocklab::model_state2_t, rocklab::model_state_t>;

/// Subscribes `handler` to `channel_regex` accepting the current type and
/// the older ones, with the typed subscription's guard and counters
/// (Bus::SubscribeDecodedOrValue: on a DirectBus an in-process Current
/// arrives as the object, an in-process older type converted by Upgrade,
/// neither encoded).
template <class Decoder>
[[nodiscard]] Subscription SubscribeVersioned(
    Bus& bus, const std::string& channel_regex,
    std::function<void(const std::string& channel, const typename Decoder::Message& msg)> handler,
    int queue_capacity = Bus::kDefaultQueue) {
  // Current's own bytes: GuardedDecode; the decoder names the older types.
  return bus.SubscribeDecodedOrValue<typename Decoder::Message>(channel_regex, Decoder{}, std::move(handler),
                                                                queue_capacity);
}

/// The sequence number of a rocklab message that carries one (raw_frame_t,
/// block_state_t, block_state2_t, table_state_t and the successors above: int64 utime, int64
/// seq right after the fingerprint), read from its bytes; and its sender
/// (event2_t.sender, health2_t.sender: the string after seq; empty for the
/// single-publisher types). False for any other type, or bytes too short.
/// `sender` points into `data`.
bool WireSeq(const void* data, int size, std::int64_t& seq, std::string_view& sender);

/// SeqGaps of one channel, kept per sender (RL_EVENT, RL_HEALTH: one stream
/// per node) and summed. At most kMaxSenders senders are told apart; the
/// messages of any beyond are counted in `unkeyed` (not checked). Allocates
/// only for a sender's first message.
/// The counts (gaps, missing, back, late, ...) are the sums over the senders.
struct ChannelSeqGaps : SeqGaps::Counts {
  static constexpr std::size_t kMaxSenders = 64;
  /// Senders are told apart by their first kMaxSenderBytes bytes.
  static constexpr std::size_t kMaxSenderBytes = 256;
  bool any{};
  std::int64_t unkeyed{};
  std::vector<std::pair<std::string, SeqGaps>> senders;
  void Add(std::string_view sender, std::int64_t seq);
};

}  // namespace rocklab::common
