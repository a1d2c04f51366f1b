#pragma once
/// @file
/// The transport seam every node talks to (as Drake's DrakeLcmInterface):
/// publish bytes or a typed LCM message on a channel, subscribe a handler to
/// a channel regex, and handle what arrived with a timeout. The
/// implementations have their own headers:
///  - common/lcm_bus.h, LcmBus: an LCM instance (udpm:// between processes,
///    memq://);
///  - common/direct_bus.h, DirectBus: in one process, Publish calls the
///    matching handlers at once (synchronous, no queue): `rocklab run`;
///  - common/log_writing_bus.h, LogWritingBus: a decorator that writes every
///    published message to an LCM log, then publishes it on the bus it wraps;
///  - common/routing_bus.h, RoutingBus: a decorator that publishes the
///    channels matching a regex on a second bus (RL_RAW on its own group).
///
/// A subscription lasts as long as the Subscription handle it returns: the
/// handle is move-only and unsubscribes when destroyed (or Reset). A handle
/// that outlives its bus does nothing.
///
/// Guarded dispatch (all buses): a typed subscription decodes inside the bus,
/// through common::GuardedDecode (common/wire.h: every string length and
/// array count checked against the bytes that remain before lcm-gen's decode
/// allocates anything). A message that does not pass never reaches the
/// handler: it is counted per channel (decode_errors()) and dropped, with a
/// warning naming the channel at most once a second per channel. A
/// handler's exception is caught, logged the same way and counted
/// (handler_errors()). Nothing escapes a handler into the transport.
///
/// Passing by value (DirectBus): a message published in the process with
/// Publish<Msg> reaches a typed subscription for the same Msg (Subscribe,
/// common::SubscribeVersioned) as the object itself, without encoding,
/// checking and decoding it, where the encoding would give the same value
/// back (common::PassesAsValue: the per-sample types of `rocklab run`, when
/// their strings hold no NUL and their arrays match their counts). A
/// versioned subscription (common::SubscribeVersioned) also takes an object
/// of one of the older types its decoder reads, converted by the same
/// Upgrade its bytes would go through (so the handler sees what decoding
/// would give). Bytes from outside the process (LcmBus, a log replayed with
/// the raw Publish) and every other subscription go the guarded way above.
/// Other buses encode every message.
///
/// Threading: handlers run on the thread that calls HandleTimeout (LcmBus)
/// or Publish (DirectBus). A bus is used by one thread at a time.

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <tuple>
#include <type_traits>
#include <typeinfo>
#include <utility>
#include <vector>

#include "common/bus_counters.h"
#include "common/encode_buffers.h"
#include "common/wire.h"

namespace rocklab {
class block_state_t;
class model_band_t;
class model_state3_t;
class raw_frame_t;
class table_state_t;
}  // namespace rocklab

namespace rocklab::common {

class Bus;

/// Whether `msg` may be handed to an in-process subscriber as it is: its
/// encoding succeeds and decodes to the same value (every string without a
/// NUL inside, every array as long as its count says). False for the types
/// not listed here (they are always encoded); the listed ones are defined in
/// common/direct_bus.cpp.
template <class Msg>
bool PassesAsValue(const Msg& /*msg*/) {
  return false;
}
template <>
bool PassesAsValue(const rocklab::block_state_t& msg);
template <>
bool PassesAsValue(const rocklab::model_band_t& msg);
template <>
bool PassesAsValue(const rocklab::model_state3_t& msg);
template <>
bool PassesAsValue(const rocklab::raw_frame_t& msg);
template <>
bool PassesAsValue(const rocklab::table_state_t& msg);

/// A typed message on its way to Bus::PublishValue: its C++ type, the object
/// and how to encode it.
struct MessageRef {
  const std::type_info* type{};
  const void* msg{};
  int (*size_fn)(const void* msg){};                        ///< getEncodedSize()
  int (*encode_fn)(const void* msg, void* buf, int size){};  ///< encode(): bytes written, < 0 on failure
  bool by_value{};  ///< PassesAsValue(msg)

  template <class Msg>
  static MessageRef Of(const Msg& m) {
    return MessageRef{&typeid(Msg), &m,
                      [](const void* p) { return static_cast<const Msg*>(p)->getEncodedSize(); },
                      [](const void* p, void* buf, int size) { return static_cast<const Msg*>(p)->encode(buf, 0, size); },
                      PassesAsValue(m)};
  }
  // EncodeBuffers' view of it.
  int getEncodedSize() const { return size_fn(msg); }
  int encode(void* buf, int /*offset: 0*/, int size) const { return encode_fn(msg, buf, size); }
};

/// A subscription on a Bus: move-only; unsubscribes when destroyed, reset or
/// assigned over. Empty when default-constructed or moved from.
class [[nodiscard]] Subscription {
 public:
  Subscription() = default;
  ~Subscription() { Reset(); }
  Subscription(Subscription&& other) noexcept
      : bus_(std::move(other.bus_)), id_(std::exchange(other.id_, 0)) {}
  Subscription& operator=(Subscription&& other) noexcept;
  Subscription(const Subscription&) = delete;
  Subscription& operator=(const Subscription&) = delete;

  /// Unsubscribes now (nothing when empty or when the bus is gone).
  void Reset() noexcept;
  /// True while it holds a subscription.
  bool active() const { return id_ != 0; }

 private:
  friend class Bus;
  Subscription(std::weak_ptr<Bus*> bus, int id) : bus_(std::move(bus)), id_(id) {}
  std::weak_ptr<Bus*> bus_;
  int id_{};
};

class Bus {
 public:
  /// channel, payload bytes, size in bytes.
  using RawHandler = std::function<void(const std::string& channel, const void* data, int size)>;
  /// channel, the published object (of the type the subscription names).
  using ValueHandler = std::function<void(const std::string& channel, const void* msg)>;
  /// A ValueHandler and the C++ type of the objects it takes.
  struct TypedValueHandler {
    const std::type_info* type{};
    ValueHandler handler;
  };
  /// LCM's default subscriber queue (30) is 30 ms of a 1 kHz channel.
  static constexpr int kDefaultQueue = 4096;

  Bus();
  virtual ~Bus();
  Bus(const Bus&) = delete;
  Bus& operator=(const Bus&) = delete;

  /// Publishes `size` bytes on `channel`. False when the transport failed
  /// (the caller counts). Never throws.
  virtual bool Publish(const std::string& channel, const void* data, int size) = 0;

  /// Encodes `msg` (an lcm-gen type) into a reused buffer and publishes it
  /// (DirectBus: hands it to typed subscriptions as it is, see the file
  /// comment). False when it does not encode or the transport failed.
  template <class Msg>
  bool Publish(const std::string& channel, const Msg& msg) {
    return PublishValue(channel, MessageRef::Of(msg));
  }

  /// Publish<Msg>'s work: here, encode and the raw Publish; DirectBus
  /// passes by value where it can.
  virtual bool PublishValue(const std::string& channel, const MessageRef& msg) {
    return encode_buffers_.EncodeThen(
        msg, [&](const void* data, int size) { return Publish(channel, data, size); });
  }

  /// Subscribes `handler` to every channel matching `channel_regex` (whole
  /// name, ECMAScript/POSIX-compatible subset as LCM's). `queue_capacity`:
  /// messages a queued transport (LcmBus) may hold before it drops.
  /// @throws std::invalid_argument for a bad regex.
  virtual Subscription SubscribeRaw(const std::string& channel_regex, RawHandler handler,
                                    int queue_capacity = kDefaultQueue) = 0;

  /// Typed subscription: decodes into a Msg kept by the subscription (no
  /// allocation per message beyond what Msg's own vectors need), guarded as
  /// the file comment says.
  template <class Msg>
  Subscription Subscribe(const std::string& channel_regex,
                         std::function<void(const std::string& channel, const Msg& msg)> handler,
                         int queue_capacity = kDefaultQueue);

  /// As Subscribe, with `decode`, a callable `const char*(const void* data,
  /// int size, Msg& msg)` returning nullptr or the reason (for a channel that
  /// carries more than one type, e.g. common::SubscribeModelState). It must
  /// guard as GuardedDecode does and never throw.
  template <class Msg, class Decode>
  Subscription SubscribeDecoded(const std::string& channel_regex, Decode decode,
                                std::function<void(const std::string& channel, const Msg& msg)> handler,
                                int queue_capacity = kDefaultQueue);

  /// As SubscribeDecoded, and where the bus passes by value (DirectBus), an
  /// in-process Publish<Msg> on a matching channel reaches `handler` as the
  /// published object itself. `decode` must read Msg's own bytes as
  /// GuardedDecode does (Subscribe, common::VersionedDecoder). When Decode
  /// names older types (`Decode::OldTypes`, a std::tuple, each read by
  /// `Decode::FromOld(const Old&, Msg&)` as `decode` reads its bytes:
  /// common::VersionedDecoder), an in-process Publish<Old> reaches `handler`
  /// converted into a Msg kept by the subscription, without encoding.
  template <class Msg, class Decode>
  Subscription SubscribeDecodedOrValue(const std::string& channel_regex, Decode decode,
                                       std::function<void(const std::string& channel, const Msg& msg)> handler,
                                       int queue_capacity = kDefaultQueue);

  /// Dispatches what has arrived, waiting up to `timeout_ms` for it.
  /// @return > 0 when messages were handled, 0 on timeout, < 0 on a transport
  ///         error. DirectBus has nothing queued: it waits and returns 0.
  virtual int HandleTimeout(int timeout_ms) = 0;

  /// Messages that did not decode, per channel (typed subscriptions; a
  /// decorator reports those of the bus it wraps).
  const std::map<std::string, std::int64_t>& decode_errors() const { return counters_->decode_errors(); }
  /// Handler exceptions caught, per channel.
  const std::map<std::string, std::int64_t>& handler_errors() const { return counters_->handler_errors(); }
  /// Totals of both.
  std::int64_t decode_error_count() const { return counters_->decode_error_count(); }
  std::int64_t handler_error_count() const { return counters_->handler_error_count(); }
  /// Typed messages this bus encoded (Publish<Msg>); a DirectBus leaves out
  /// those it passed by value to every subscription.
  std::int64_t encode_count() const { return encode_buffers_.encoded(); }

 protected:
  /// A decorator's base: it counts into the counters of `wrapped`.
  struct SharesCountersWith {
    const Bus& wrapped;
  };
  explicit Bus(SharesCountersWith shared);

  /// SubscribeRaw with `values`, the handlers of objects published in the
  /// process, one per type taken (the first match is used), for a bus that
  /// passes by value. Here: `values` are not used (every message arrives as
  /// bytes).
  virtual Subscription SubscribeRawOrValue(const std::string& channel_regex, RawHandler raw,
                                           std::vector<TypedValueHandler> /*values*/, int queue_capacity) {
    return SubscribeRaw(channel_regex, std::move(raw), queue_capacity);
  }
  /// Runs a value handler on one message, as Dispatch.
  void DispatchValue(const ValueHandler& handler, const std::string& channel, const void* msg) {
    counters_->DispatchValue(handler, channel, msg);
  }
  /// Encodes `msg` into the reused buffer of the current depth and calls
  /// `then(data, size)`; false when it does not encode.
  template <class Then>
  bool EncodeThen(const MessageRef& msg, Then&& then) {
    return encode_buffers_.EncodeThen(msg, std::forward<Then>(then));
  }

  /// The handle of subscription `id` of this bus (an implementation's
  /// SubscribeRaw returns it; a decorator returns its inner bus's handle).
  Subscription MakeSubscription(int id) const { return Subscription(self_, id); }
  /// Runs `handler` on one message, exceptions caught, logged and counted.
  void Dispatch(const RawHandler& handler, const std::string& channel, const void* data, int size) {
    counters_->Dispatch(handler, channel, data, size);
  }

 private:
  friend class Subscription;
  /// Ends subscription `id` (called by its handle). A bus that only hands
  /// out another bus's handles (a decorator) has nothing to end.
  virtual void Unsubscribe(int /*id*/) {}

  std::shared_ptr<BusCounters> counters_;
  std::shared_ptr<Bus*> self_;  // what the handles watch: gone with the bus
  EncodeBuffers encode_buffers_;
};

/// The sample-clock utime of a rocklab message's bytes (after the 8-byte
/// fingerprint), us; `fallback` when it is shorter than 16 bytes.
std::int64_t PayloadUtime(const void* data, int size, std::int64_t fallback);

// ---- templates ----

template <class Msg, class Decode>
Subscription Bus::SubscribeDecoded(const std::string& channel_regex, Decode decode,
                                   std::function<void(const std::string&, const Msg&)> handler,
                                   int queue_capacity) {
  return SubscribeRaw(
      channel_regex,
      [counters = counters_, decode = std::move(decode), handler = std::move(handler), msg = Msg{}](
          const std::string& channel, const void* data, int size) mutable {
        if (const char* why = decode(data, size, msg)) {
          counters->CountDecodeError(channel, why);
          return;
        }
        handler(channel, msg);
      },
      queue_capacity);
}

namespace detail {
// Decode::OldTypes, or an empty tuple.
template <class Decode, class = void>
struct OldTypesOf {
  using type = std::tuple<>;
};
template <class Decode>
struct OldTypesOf<Decode, std::void_t<typename Decode::OldTypes>> {
  using type = typename Decode::OldTypes;
};
// One handler per older type: the object converted into `scratch`, then `handler`.
template <class Msg, class Decode, class Handler, class... Old>
void AddOldValueHandlers(std::vector<Bus::TypedValueHandler>& values, const Handler& handler,
                         std::tuple<Old...>* /*types*/) {
  if constexpr (sizeof...(Old) > 0) {
    auto scratch = std::make_shared<Msg>();
    (values.push_back({&typeid(Old),
                       [handler, scratch](const std::string& channel, const void* old) {
                         Decode::FromOld(*static_cast<const Old*>(old), *scratch);
                         (*handler)(channel, *scratch);
                       }}),
     ...);
  }
}
}  // namespace detail

template <class Msg, class Decode>
Subscription Bus::SubscribeDecodedOrValue(const std::string& channel_regex, Decode decode,
                                          std::function<void(const std::string&, const Msg&)> handler,
                                          int queue_capacity) {
  auto shared = std::make_shared<std::function<void(const std::string&, const Msg&)>>(std::move(handler));
  RawHandler raw = [counters = counters_, decode = std::move(decode), shared, msg = Msg{}](
                       const std::string& channel, const void* data, int size) mutable {
    if (const char* why = decode(data, size, msg)) {
      counters->CountDecodeError(channel, why);
      return;
    }
    (*shared)(channel, msg);
  };
  std::vector<TypedValueHandler> values;
  values.push_back({&typeid(Msg), [shared](const std::string& channel, const void* msg) {
                      (*shared)(channel, *static_cast<const Msg*>(msg));
                    }});
  detail::AddOldValueHandlers<Msg, Decode>(values, shared,
                                           static_cast<typename detail::OldTypesOf<Decode>::type*>(nullptr));
  return SubscribeRawOrValue(channel_regex, std::move(raw), std::move(values), queue_capacity);
}

template <class Msg>
Subscription Bus::Subscribe(const std::string& channel_regex,
                            std::function<void(const std::string&, const Msg&)> handler,
                            int queue_capacity) {
  return SubscribeDecodedOrValue<Msg>(
      channel_regex,
      [](const void* data, int size, Msg& msg) { return GuardedDecode(data, size, msg); },
      std::move(handler), queue_capacity);
}

}  // namespace rocklab::common
