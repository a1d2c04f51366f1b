#pragma once
/// @file
/// The transport seam every node talks to: publish bytes or a typed LCM
/// message on a channel, subscribe a handler to a channel regex, and handle
/// what arrived with a timeout. Three implementations:
///  - LcmBus: an LCM instance (udpm:// between processes, memq://);
///  - DirectBus: in one process, Publish calls the matching handlers at once
///    (synchronous, no queue, no copy through memq): `rocklab run`;
///  - LogWritingBus: a decorator that writes every published message to an
///    LCM log (common::LogWriter), then publishes it on the bus it wraps;
///  - RoutingBus: a decorator that publishes the channels matching a regex
///    on a second bus (RL_RAW on its own udpm group: common/bus_urls.h).
///
/// Guarded dispatch (all buses): a typed subscription decodes inside the bus,
/// through common::GuardedDecode: the wire pre-check (common/wire.h: every
/// string length and array count within the bytes that remain, before
/// lcm-gen's decode allocates anything), then decode(). A message that does
/// not pass never reaches the handler: it is counted per channel (decode_errors()) and
/// dropped, with a warning naming the channel at most once a second per
/// channel. A handler's exception is caught, logged the same way and counted
/// (handler_errors()). Nothing escapes a handler into the transport.
///
/// Threading: handlers run on the thread that calls HandleTimeout (LcmBus)
/// or Publish (DirectBus). A bus is used by one thread at a time.

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "common/wire.h"

namespace rocklab::common {

class LogWriter;

class Bus {
 public:
  /// channel, payload bytes, size in bytes.
  using RawHandler = std::function<void(const std::string& channel, const void* data, int size)>;
  using SubscriptionId = int;
  /// LCM's default subscriber queue (30) is 30 ms of a 1 kHz channel.
  static constexpr int kDefaultQueue = 4096;

  Bus() = default;
  virtual ~Bus() = default;
  Bus(const Bus&) = delete;
  Bus& operator=(const Bus&) = delete;

  /// Publishes `size` bytes on `channel`. False when the transport failed
  /// (the caller counts). Never throws.
  virtual bool Publish(const std::string& channel, const void* data, int size) = 0;

  /// Encodes `msg` (an lcm-gen type) into a reused buffer and publishes it.
  template <class Msg>
  bool Publish(const std::string& channel, const Msg& msg);

  /// Subscribes `handler` to every channel matching `channel_regex` (whole
  /// name, ECMAScript/POSIX-compatible subset as LCM's). `queue_capacity`:
  /// messages a queued transport (LcmBus) may hold before it drops.
  /// @throws std::invalid_argument for a bad regex.
  virtual SubscriptionId SubscribeRaw(const std::string& channel_regex, RawHandler handler,
                                      int queue_capacity = kDefaultQueue) = 0;

  /// Typed subscription: decodes into a Msg kept by the subscription (no
  /// allocation per message beyond what Msg's own vectors need), guarded as
  /// the file comment says.
  template <class Msg>
  SubscriptionId Subscribe(const std::string& channel_regex,
                           std::function<void(const std::string& channel, const Msg& msg)> handler,
                           int queue_capacity = kDefaultQueue);

  /// As Subscribe, with `decode`, a callable `const char*(const void* data,
  /// int size, Msg& msg)` returning nullptr or the reason (for a channel that
  /// carries more than one type, e.g. common::SubscribeModelState). It must
  /// guard as GuardedDecode does and never throw.
  template <class Msg, class Decode>
  SubscriptionId SubscribeDecoded(const std::string& channel_regex, Decode decode,
                                  std::function<void(const std::string& channel, const Msg& msg)> handler,
                                  int queue_capacity = kDefaultQueue);

  virtual void Unsubscribe(SubscriptionId id) = 0;

  /// Dispatches what has arrived, waiting up to `timeout_ms` for it.
  /// @return > 0 when messages were handled, 0 on timeout, < 0 on a transport
  ///         error. DirectBus has nothing queued: it waits and returns 0.
  virtual int HandleTimeout(int timeout_ms) = 0;

  /// Messages that did not decode, per channel (typed subscriptions; a
  /// decorator reports those of the bus it wraps).
  const std::map<std::string, std::int64_t>& decode_errors() const { return root().decode_errors_; }
  /// Handler exceptions caught, per channel.
  const std::map<std::string, std::int64_t>& handler_errors() const { return root().handler_errors_; }
  /// Totals of both.
  std::int64_t decode_error_count() const;
  std::int64_t handler_error_count() const;

 protected:
  /// The bus that keeps the counters: itself, or for a decorator the bus it wraps.
  virtual const Bus& root() const { return *this; }
  Bus& root() { return const_cast<Bus&>(static_cast<const Bus*>(this)->root()); }
  /// Runs `handler` on one message, exceptions caught, logged and counted.
  void Dispatch(const RawHandler& handler, const std::string& channel, const void* data, int size);

 private:
  void CountDecodeError(const std::string& channel, const char* why);
  void Warn(std::map<std::string, double>& last, const std::string& channel, const std::string& what);

  std::map<std::string, std::int64_t> decode_errors_, handler_errors_;
  std::map<std::string, double> last_decode_warning_s_, last_handler_warning_s_;
  // Encoding buffers, one per nesting depth (a DirectBus handler publishing
  // while its message is still being dispatched must not overwrite it).
  std::vector<std::vector<std::uint8_t>> encode_buffers_;
  int encode_depth_{};
};

/// An LCM instance behind the Bus interface (PIMPL: no LCM header here).
class LcmBus final : public Bus {
 public:
  /// @param url LCM URL; empty: LCM_DEFAULT_URL or LCM's own default.
  /// @throws std::runtime_error naming the URL when LCM does not open it.
  explicit LcmBus(const std::string& url);
  ~LcmBus() override;

  using Bus::Publish;
  bool Publish(const std::string& channel, const void* data, int size) override;
  SubscriptionId SubscribeRaw(const std::string& channel_regex, RawHandler handler,
                              int queue_capacity = kDefaultQueue) override;
  void Unsubscribe(SubscriptionId id) override;
  int HandleTimeout(int timeout_ms) override;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// In-process, synchronous: Publish runs every matching handler before it
/// returns, in subscription order. A handler may publish (nested dispatch).
class DirectBus final : public Bus {
 public:
  DirectBus();
  ~DirectBus() override;

  using Bus::Publish;
  bool Publish(const std::string& channel, const void* data, int size) override;
  SubscriptionId SubscribeRaw(const std::string& channel_regex, RawHandler handler,
                              int queue_capacity = kDefaultQueue) override;
  void Unsubscribe(SubscriptionId id) override;
  /// Nothing is ever queued: sleeps `timeout_ms` (a node's idle loop) and returns 0.
  int HandleTimeout(int timeout_ms) override;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Writes each published message to `log` (stamp: the message's utime, the
/// int64 after the 8-byte fingerprint every rocklab type starts with; the
/// writer keeps stamps non-decreasing), then publishes it on `inner`.
/// Subscriptions and HandleTimeout go to `inner`. Both are not owned and
/// must outlive the decorator.
class LogWritingBus final : public Bus {
 public:
  LogWritingBus(Bus& inner, LogWriter& log);

  using Bus::Publish;
  bool Publish(const std::string& channel, const void* data, int size) override;
  SubscriptionId SubscribeRaw(const std::string& channel_regex, RawHandler handler,
                              int queue_capacity = kDefaultQueue) override;
  void Unsubscribe(SubscriptionId id) override;
  int HandleTimeout(int timeout_ms) override;

 protected:
  using Bus::root;
  const Bus& root() const override { return inner_; }

 private:
  Bus& inner_;      // not owned
  LogWriter& log_;  // not owned
};

/// Publishes each message whose channel matches `channel_regex` (whole name)
/// on `routed`, every other on `main`: the raw frames' publishers (the DAQ
/// stage, replay) send RL_RAW to its own group this way
/// (common/bus_urls.h). A publisher's bus: subscriptions and HandleTimeout
/// go to `main` (and its counters are main's). Whether a channel matches is
/// decided once per channel name (a lookup per message, no allocation after
/// a channel's first message). Both buses are not owned and must outlive it.
class RoutingBus final : public Bus {
 public:
  /// @throws std::invalid_argument for a bad regex.
  RoutingBus(Bus& main, Bus& routed, const std::string& channel_regex);
  ~RoutingBus() override;

  using Bus::Publish;
  bool Publish(const std::string& channel, const void* data, int size) override;
  SubscriptionId SubscribeRaw(const std::string& channel_regex, RawHandler handler,
                              int queue_capacity = kDefaultQueue) override;
  void Unsubscribe(SubscriptionId id) override;
  int HandleTimeout(int timeout_ms) override;

 protected:
  using Bus::root;
  const Bus& root() const override { return main_; }

 private:
  struct Impl;
  Bus& main_;    // not owned
  Bus& routed_;  // not owned
  std::unique_ptr<Impl> impl_;
};

/// The sample-clock utime of a rocklab message's bytes (after the 8-byte
/// fingerprint), us; `fallback` when it is shorter than 16 bytes.
std::int64_t PayloadUtime(const void* data, int size, std::int64_t fallback);

// ---- templates ----

template <class Msg>
bool Bus::Publish(const std::string& channel, const Msg& msg) {
  if (static_cast<int>(encode_buffers_.size()) <= encode_depth_) encode_buffers_.emplace_back();
  std::vector<std::uint8_t>& buf = encode_buffers_[encode_depth_];
  const int size = msg.getEncodedSize();
  if (size < 0) return false;
  if (buf.size() < static_cast<std::size_t>(size)) buf.resize(size);
  if (msg.encode(buf.data(), 0, size) != size) return false;
  ++encode_depth_;
  const bool ok = Publish(channel, buf.data(), size);
  --encode_depth_;
  return ok;
}

template <class Msg, class Decode>
Bus::SubscriptionId Bus::SubscribeDecoded(const std::string& channel_regex, Decode decode,
                                          std::function<void(const std::string&, const Msg&)> handler,
                                          int queue_capacity) {
  return SubscribeRaw(
      channel_regex,
      [this, decode = std::move(decode), handler = std::move(handler), msg = Msg{}](
          const std::string& channel, const void* data, int size) mutable {
        if (const char* why = decode(data, size, msg)) {
          CountDecodeError(channel, why);
          return;
        }
        handler(channel, msg);
      },
      queue_capacity);
}

template <class Msg>
Bus::SubscriptionId Bus::Subscribe(const std::string& channel_regex,
                                   std::function<void(const std::string&, const Msg&)> handler,
                                   int queue_capacity) {
  return SubscribeDecoded<Msg>(
      channel_regex,
      [](const void* data, int size, Msg& msg) { return GuardedDecode(data, size, msg); },
      std::move(handler), queue_capacity);
}

}  // namespace rocklab::common
