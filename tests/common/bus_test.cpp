// The transport seam: typed publish/subscribe on the direct and LCM buses,
// guarded decoding (short, foreign and hostile payloads counted per channel
// and dropped, never thrown into the transport), handler exceptions caught
// and counted, and the log-writing decorator.
#include "common/bus.h"

#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <vector>

#include "common/direct_bus.h"
#include "common/lcm_bus.h"
#include "common/lcm_log.h"
#include "common/log_writing_bus.h"
#include "common/versions.h"
#include "rocklab/block_state_t.hpp"
#include "rocklab/model_state3_t.hpp"
#include "rocklab/model_state4_t.hpp"
#include "rocklab/raw_frame_t.hpp"
#include "tests/scratch.h"

namespace rocklab::common {
namespace {

rocklab::block_state_t Theta(std::int64_t utime, double theta) {
  rocklab::block_state_t m{};
  m.utime = utime;
  m.theta = theta;
  return m;
}

// A raw_frame_t whose num_channels says -1: lcm-gen's decoder asks the
// vector for SIZE_MAX elements and throws std::length_error.
std::vector<std::uint8_t> HostileRawFrame() {
  rocklab::raw_frame_t m{};
  m.utime = 1;
  m.num_channels = 0;
  std::vector<std::uint8_t> b(m.getEncodedSize());
  m.encode(b.data(), 0, static_cast<int>(b.size()));
  // fingerprint 8, utime 8, seq 8: num_channels at byte 24.
  for (int i = 24; i < 28; ++i) b[i] = 0xff;
  return b;
}

// Oracle: what was published, in order, to every matching subscription in
// the order they were made; a handler publishing inside a dispatch does not
// disturb the message being dispatched.
TEST(DirectBus, DeliversTypedMessagesSynchronouslyInSubscriptionOrder) {
  DirectBus bus;
  std::vector<std::string> seen;
  const common::Subscription sub1 = bus.Subscribe<rocklab::block_state_t>("RL_THETA", [&](const std::string& c, const rocklab::block_state_t& m) {
    seen.push_back("first " + c + " " + std::to_string(m.utime));
    if (m.utime == 1) bus.Publish("RL_THETA_ECHO", Theta(100, 0.5));  // nested
  });
  const common::Subscription sub2 = bus.Subscribe<rocklab::block_state_t>("RL_THETA.*", [&](const std::string& c, const rocklab::block_state_t& m) {
    seen.push_back("second " + c + " " + std::to_string(m.utime) + " " + std::to_string(m.theta));
  });
  EXPECT_TRUE(bus.Publish("RL_THETA", Theta(1, 0.25)));
  EXPECT_TRUE(bus.Publish("OTHER", Theta(2, 0.0)));
  const std::vector<std::string> expected = {
      "first RL_THETA 1", "second RL_THETA_ECHO 100 0.500000", "second RL_THETA 1 0.250000"};
  EXPECT_EQ(seen, expected);
  EXPECT_EQ(bus.decode_error_count(), 0);
}

// Oracle: the dispatch rules written in direct_bus.cpp, which hold however
// the bus caches its channel routes: a subscription made by a handler gets
// the next message (and messages published inside the dispatch after it),
// not the one being dispatched; one ended by a handler gets nothing more,
// even of the message being dispatched; every channel's route follows.
TEST(DirectBus, SubscriptionsChangedInsideADispatchTakeEffectInOrder) {
  DirectBus bus;
  std::vector<std::string> seen;
  common::Subscription late, victim;
  victim = bus.Subscribe<rocklab::block_state_t>("RL_THETA", [&](const std::string& c, const rocklab::block_state_t& m) {
    seen.push_back("victim " + c + " " + std::to_string(m.utime));
  });
  const common::Subscription first = bus.Subscribe<rocklab::block_state_t>(
      "RL_.*", [&](const std::string& c, const rocklab::block_state_t& m) {
        seen.push_back("first " + c + " " + std::to_string(m.utime));
        if (m.utime == 2) {
          late = bus.Subscribe<rocklab::block_state_t>("RL_THETA.*", [&](const std::string& c2, const rocklab::block_state_t& m2) {
            seen.push_back("late " + c2 + " " + std::to_string(m2.utime));
          });
          bus.Publish("RL_THETA_ECHO", Theta(20, 0.0));  // nested, after the subscription
        }
        if (m.utime == 3) victim = common::Subscription();  // ends it
      });
  const common::Subscription after = bus.Subscribe<rocklab::block_state_t>("RL_THETA", [&](const std::string& c, const rocklab::block_state_t& m) {
    seen.push_back("after " + c + " " + std::to_string(m.utime));
  });
  for (int i = 0; i < 3; ++i) bus.Publish("RL_THETA", Theta(1, 0.0));  // routes cached before the changes
  seen.clear();
  bus.Publish("RL_THETA", Theta(2, 0.0));
  bus.Publish("RL_THETA", Theta(3, 0.0));
  bus.Publish("RL_THETA", Theta(4, 0.0));
  bus.Publish("RL_OTHER", Theta(5, 0.0));
  const std::vector<std::string> expected = {
      "victim RL_THETA 2", "first RL_THETA 2", "first RL_THETA_ECHO 20", "late RL_THETA_ECHO 20",
      "after RL_THETA 2",
      "victim RL_THETA 3", "first RL_THETA 3", "after RL_THETA 3", "late RL_THETA 3",
      "first RL_THETA 4", "after RL_THETA 4", "late RL_THETA 4",
      "first RL_OTHER 5"};
  EXPECT_EQ(seen, expected);
}

// Oracle: the guard's contract: a short payload (decode < 0), another
// type's payload (fingerprint mismatch) and a hostile length (length_error)
// are each counted on their channel and dropped; a throwing handler is
// counted and the next subscriber still gets the message; nothing throws
// out of Publish.
TEST(DirectBus, UndecodableMessagesAndHandlerExceptionsAreCountedNotThrown) {
  DirectBus bus;
  int thetas = 0, frames = 0, after_throw = 0;
  const common::Subscription sub3 = bus.Subscribe<rocklab::block_state_t>("RL_THETA", [&](const std::string&, const rocklab::block_state_t&) { ++thetas; });
  const common::Subscription sub4 = bus.Subscribe<rocklab::raw_frame_t>("RL_RAW", [&](const std::string&, const rocklab::raw_frame_t& m) {
    ++frames;
    if (m.seq == 7) throw std::runtime_error("handler bug");
  });
  const common::Subscription sub5 = bus.SubscribeRaw("RL_RAW", [&](const std::string&, const void*, int) { ++after_throw; });

  const char shortish[5] = {1, 2, 3, 4, 5};
  EXPECT_NO_THROW(bus.Publish("RL_THETA", shortish, 5));
  rocklab::raw_frame_t frame{};
  frame.seq = 7;
  EXPECT_NO_THROW(bus.Publish("RL_THETA", frame));  // another type
  const std::vector<std::uint8_t> hostile = HostileRawFrame();
  EXPECT_NO_THROW(bus.Publish("RL_RAW", hostile.data(), static_cast<int>(hostile.size())));
  EXPECT_NO_THROW(bus.Publish("RL_RAW", frame));  // decodes; its handler throws
  EXPECT_NO_THROW(bus.Publish("RL_THETA", Theta(3, 0.1)));

  EXPECT_EQ(thetas, 1);
  EXPECT_EQ(frames, 1);
  EXPECT_EQ(after_throw, 2);  // raw handlers get every payload
  EXPECT_EQ(bus.decode_errors().at("RL_THETA"), 2);
  EXPECT_EQ(bus.decode_errors().at("RL_RAW"), 1);
  EXPECT_EQ(bus.handler_errors().at("RL_RAW"), 1);
  EXPECT_EQ(bus.decode_error_count(), 3);
  EXPECT_EQ(bus.handler_error_count(), 1);
}

// Oracle: bus.h's "Passing by value": a typed subscription of the
// published type gets the published object itself (its address), a raw one
// on the same channel the bytes lcm-gen encodes, which decode to the same
// fields; a message whose encoding would not give it back (a NUL inside a
// string: encode() writes less than getEncodedSize(); an array longer than
// its count) goes the encoded way as before: refused, or decoded (the
// subscription sees the count's elements); a subscription of another type
// on the channel gets bytes and counts them as undecodable; a channel
// nobody subscribes to takes the message.
TEST(DirectBus, PassesItsOwnMessagesByValueWhereTheEncodingGivesThemBack) {
  DirectBus bus;
  const void* typed_at = nullptr;
  rocklab::block_state_t raw_decoded{};
  int raw_calls = 0;
  const common::Subscription typed = bus.Subscribe<rocklab::block_state_t>(
      "RL_THETA", [&](const std::string&, const rocklab::block_state_t& m) { typed_at = &m; });
  const common::Subscription raw = bus.SubscribeRaw("RL_THETA", [&](const std::string&, const void* data, int size) {
    ++raw_calls;
    EXPECT_EQ(GuardedDecode(data, size, raw_decoded), nullptr);
  });
  const rocklab::block_state_t theta = Theta(7, -0.125);
  EXPECT_TRUE(bus.Publish("RL_THETA", theta));
  EXPECT_EQ(typed_at, static_cast<const void*>(&theta));
  EXPECT_EQ(raw_calls, 1);
  EXPECT_EQ(raw_decoded.utime, 7);
  EXPECT_EQ(raw_decoded.theta, -0.125);

  std::vector<const void*> models;
  std::vector<std::string> names;
  const common::Subscription versioned = SubscribeVersioned<ModelStateDecoder>(
      bus, "RL_MODEL_.*", [&](const std::string&, const rocklab::model_state3_t& m) {
        models.push_back(&m);
        names.push_back(m.name);
      });
  int wrong_type_calls = 0;
  const common::Subscription wrong_type = bus.Subscribe<rocklab::block_state_t>(
      "RL_MODEL_A", [&](const std::string&, const rocklab::block_state_t&) { ++wrong_type_calls; });
  rocklab::model_state3_t model{};
  model.name = "A";
  model.model = "housner";
  EXPECT_TRUE(bus.Publish("RL_MODEL_A", model));
  ASSERT_EQ(models.size(), 1u);
  EXPECT_EQ(models[0], static_cast<const void*>(&model));
  EXPECT_EQ(wrong_type_calls, 0);
  EXPECT_EQ(bus.decode_errors().at("RL_MODEL_A"), 1);  // the block_state_t subscription got the bytes
  model.name = std::string("A\0B", 3);
  EXPECT_FALSE(bus.Publish("RL_MODEL_A", model));  // does not encode: nobody gets it
  EXPECT_EQ(models.size(), 1u);
  EXPECT_EQ(bus.decode_errors().at("RL_MODEL_A"), 1);

  std::vector<std::size_t> frame_sizes;
  std::vector<const void*> frames;
  const common::Subscription raw_frames = bus.Subscribe<rocklab::raw_frame_t>(
      "RL_RAW", [&](const std::string&, const rocklab::raw_frame_t& m) {
        frames.push_back(&m);
        frame_sizes.push_back(m.values.size());
      });
  rocklab::raw_frame_t frame{};
  frame.num_channels = 2;
  frame.values = {1.0, 2.0, 3.0};
  EXPECT_TRUE(bus.Publish("RL_RAW", frame));
  frame.values.pop_back();
  EXPECT_TRUE(bus.Publish("RL_RAW", frame));
  ASSERT_EQ(frames.size(), 2u);
  EXPECT_NE(frames[0], static_cast<const void*>(&frame));  // decoded from bytes
  EXPECT_EQ(frame_sizes[0], 2u);
  EXPECT_EQ(frames[1], static_cast<const void*>(&frame));
  EXPECT_TRUE(bus.Publish("RL_NOBODY", frame));
  EXPECT_EQ(bus.handler_error_count(), 0);
}

// Encodes an lcm-gen message into its bytes.
template <class Msg>
std::vector<std::uint8_t> EncodedBytes(const Msg& m) {
  std::vector<std::uint8_t> b(static_cast<std::size_t>(m.getEncodedSize()));
  EXPECT_EQ(m.encode(b.data(), 0, static_cast<int>(b.size())), static_cast<int>(b.size()));
  return b;
}

// Oracle: the same message's bytes through the guarded decoder
// (ModelStateBodiesDecoder: decode the model_state3_t, then Upgrade) give
// the model_state4_t the subscription saw, byte for byte when encoded
// again; bus.h's "Passing by value": an older type a versioned
// subscription reads is handed as the object and converted, not encoded
// (the bus's encode_count stays 0) while no subscription wants bytes; a raw
// subscription on the channel makes one encoding per message, and the
// versioned one still sees the same value; a message whose encoding would
// not give it back (a NUL in its name) is encoded and refused, as before.
TEST(DirectBus, PassesAnOlderTypeByValueToAVersionedSubscription) {
  DirectBus bus;
  std::vector<rocklab::model_state4_t> seen;
  const common::Subscription versioned = SubscribeVersioned<ModelStateBodiesDecoder>(
      bus, "RL_MODEL_.*", [&](const std::string&, const rocklab::model_state4_t& m) { seen.push_back(m); });
  rocklab::model_state3_t m3{};
  m3.utime = 123456;
  m3.seq = 41;
  m3.name = "fitted_housner";
  m3.model = "housner";
  m3.theta = 0.0125;
  m3.theta_dot = -0.25;
  m3.chi = 0.5;
  m3.psi = 1.5;
  m3.energy = 0.75;
  m3.impact_count = 3;
  m3.regime = -1;
  m3.alpha = 0.235;
  m3.p = 3.884;
  m3.mu = 0.937;
  m3.l = 1e-10;
  m3.equations = rocklab::model_state3_t::EQUATIONS_EQ10;
  EXPECT_TRUE(bus.Publish("RL_MODEL_fitted_housner", m3));
  EXPECT_EQ(bus.encode_count(), 0);
  const std::vector<std::uint8_t> bytes = EncodedBytes(m3);
  EXPECT_TRUE(bus.Publish("RL_MODEL_fitted_housner", bytes.data(), static_cast<int>(bytes.size())));
  ASSERT_EQ(seen.size(), 2u);
  EXPECT_EQ(EncodedBytes(seen[0]), EncodedBytes(seen[1]));
  EXPECT_EQ(seen[0].nbodies, 1);
  ASSERT_EQ(seen[0].theta.size(), 1u);
  EXPECT_EQ(seen[0].theta[0], 0.0125);
  EXPECT_EQ(seen[0].seq, 41);
  EXPECT_EQ(seen[0].name, "fitted_housner");
  EXPECT_EQ(seen[0].mode, "");

  int raw_calls = 0;
  const common::Subscription raw =
      bus.SubscribeRaw("RL_MODEL_.*", [&](const std::string&, const void*, int) { ++raw_calls; });
  m3.theta = -0.5;
  EXPECT_TRUE(bus.Publish("RL_MODEL_fitted_housner", m3));
  EXPECT_EQ(bus.encode_count(), 1);
  EXPECT_EQ(raw_calls, 1);
  ASSERT_EQ(seen.size(), 3u);
  EXPECT_EQ(seen[2].theta[0], -0.5);

  m3.name = std::string("A\0B", 3);
  EXPECT_FALSE(bus.Publish("RL_MODEL_A", m3));
  EXPECT_EQ(bus.encode_count(), 2);
  EXPECT_EQ(seen.size(), 3u);
  EXPECT_EQ(raw_calls, 1);
  EXPECT_EQ(bus.decode_error_count(), 0);
  EXPECT_EQ(bus.handler_error_count(), 0);
}

// Oracle: a handler that throws on a message passed by value is counted on
// its channel as on bytes, and the next subscription still gets it.
TEST(DirectBus, HandlerExceptionsOnMessagesPassedByValueAreCounted) {
  DirectBus bus;
  int after = 0;
  const common::Subscription thrower = bus.Subscribe<rocklab::block_state_t>(
      "RL_THETA", [&](const std::string&, const rocklab::block_state_t&) { throw std::runtime_error("bug"); });
  const common::Subscription next = bus.Subscribe<rocklab::block_state_t>(
      "RL_THETA", [&](const std::string&, const rocklab::block_state_t&) { ++after; });
  EXPECT_NO_THROW(bus.Publish("RL_THETA", Theta(1, 0.0)));
  EXPECT_EQ(after, 1);
  EXPECT_EQ(bus.handler_errors().at("RL_THETA"), 1);
}

// Oracle: the same guard on LCM's own dispatch (memq://): the hostile
// payload goes through liblcm and is counted, not thrown out of handleTimeout.
TEST(LcmBus, GuardedDecodeOnLcmDispatch) {
  LcmBus bus("memq://");
  int frames = 0;
  const common::Subscription sub6 = bus.Subscribe<rocklab::raw_frame_t>("RL_RAW", [&](const std::string&, const rocklab::raw_frame_t&) { ++frames; });
  const std::vector<std::uint8_t> hostile = HostileRawFrame();
  ASSERT_TRUE(bus.Publish("RL_RAW", hostile.data(), static_cast<int>(hostile.size())));
  rocklab::raw_frame_t good{};
  ASSERT_TRUE(bus.Publish("RL_RAW", good));
  int handled = 0;
  EXPECT_NO_THROW({
    while (bus.HandleTimeout(0) > 0) ++handled;
  });
  EXPECT_EQ(handled, 2);
  EXPECT_EQ(frames, 1);
  EXPECT_EQ(bus.decode_errors().at("RL_RAW"), 1);
  EXPECT_THROW(LcmBus("nonsense://"), std::runtime_error);
}

// Oracle: the decorator writes each message as published, stamped with its
// utime raised to keep the stamps in order, and still delivers it.
TEST(LogWritingBus, WritesEveryPublishedMessageWithStampsInOrder) {
  const std::string path =
      test::ScratchDir("bus_test") + "/log.lcm";
  DirectBus direct;
  int delivered = 0;
  const common::Subscription sub7 = direct.Subscribe<rocklab::block_state_t>("RL_THETA", [&](const std::string&, const rocklab::block_state_t&) { ++delivered; });
  {
    LogWriter writer(path);
    LogWritingBus bus(direct, writer);
    for (std::int64_t utime : {1000, 3000, 2000, 4000}) EXPECT_TRUE(bus.Publish("RL_THETA", Theta(utime, 0.0)));
    EXPECT_EQ(writer.events(), 4);
    EXPECT_EQ(writer.raised_stamps(), 1);
  }
  EXPECT_EQ(delivered, 4);
  LogReader reader(path);
  LogEvent ev;
  std::vector<std::int64_t> stamps, utimes;
  while (reader.Next(ev)) {
    stamps.push_back(ev.timestamp_us);
    rocklab::block_state_t m;
    ASSERT_GE(m.decode(ev.data.data(), 0, static_cast<int>(ev.data.size())), 0);
    utimes.push_back(m.utime);
  }
  EXPECT_EQ(stamps, (std::vector<std::int64_t>{1000, 3000, 3000, 4000}));
  EXPECT_EQ(utimes, (std::vector<std::int64_t>{1000, 3000, 2000, 4000}));  // payloads unchanged
}

// Oracle: the handle's documented life: a subscription delivers while its
// handle lives, moves with it, ends when it is destroyed or Reset (also
// from inside a dispatch), and a handle that outlives its bus does nothing.
TEST(Subscription, LastsAsLongAsItsHandle) {
  auto bus = std::make_unique<DirectBus>();
  int a = 0, b = 0;
  Subscription keep;
  {
    Subscription sa = bus->SubscribeRaw("X", [&](const std::string&, const void*, int) { ++a; });
    Subscription sb = bus->SubscribeRaw("X", [&](const std::string&, const void*, int) { ++b; });
    EXPECT_TRUE(bus->Publish("X", "1", 1));
    keep = std::move(sb);  // moves: still subscribed
    EXPECT_FALSE(sb.active());
  }  // sa ends here
  EXPECT_TRUE(bus->Publish("X", "2", 1));
  EXPECT_EQ(a, 1);
  EXPECT_EQ(b, 2);
  EXPECT_TRUE(keep.active());
  keep.Reset();
  EXPECT_FALSE(keep.active());
  EXPECT_TRUE(bus->Publish("X", "3", 1));
  EXPECT_EQ(b, 2);

  // A handler ending its own subscription: this message is its last.
  Subscription self;
  int c = 0;
  self = bus->SubscribeRaw("Y", [&](const std::string&, const void*, int) {
    ++c;
    self.Reset();
  });
  EXPECT_TRUE(bus->Publish("Y", "1", 1));
  EXPECT_TRUE(bus->Publish("Y", "2", 1));
  EXPECT_EQ(c, 1);

  Subscription outlives = bus->SubscribeRaw("Z", [](const std::string&, const void*, int) {});
  bus.reset();
  outlives.Reset();  // the bus is gone: nothing to end, no crash (ASan build checks)
  EXPECT_FALSE(outlives.active());
}

// Oracle: as on the DirectBus above, through liblcm's dispatch (memq://):
// a handler ending its own subscription sees no later message and frees
// nothing it is still running on (the ASan build checks).
TEST(Subscription, EndsFromItsOwnHandlerOnLcm) {
  LcmBus bus("memq://");
  Subscription self;
  int c = 0;
  self = bus.SubscribeRaw("Y", [&](const std::string& channel, const void*, int) {
    self.Reset();
    ++c;
    EXPECT_EQ(channel, "Y");  // the handler's own state is still alive
  });
  for (int k = 0; k < 3; ++k) ASSERT_TRUE(bus.Publish("Y", "1", 1));
  while (bus.HandleTimeout(0) > 0) {
  }
  EXPECT_EQ(c, 1);
  EXPECT_FALSE(self.active());
  int d = 0;
  const Subscription again = bus.SubscribeRaw("Y", [&](const std::string&, const void*, int) { ++d; });
  ASSERT_TRUE(bus.Publish("Y", "2", 1));
  while (bus.HandleTimeout(0) > 0) {
  }
  EXPECT_EQ(d, 1);
}

// Oracle: a decorator's subscriptions are its inner bus's, so they end with
// their handles too, and the counters are the inner bus's.
TEST(Subscription, ThroughADecoratorEndsOnTheInnerBus) {
  const std::string path = test::ScratchDir("bus_test") + "/decorated.lcm";
  DirectBus direct;
  LogWriter writer(path);
  LogWritingBus bus(direct, writer);
  int n = 0;
  {
    const Subscription s = bus.SubscribeRaw("X", [&](const std::string&, const void*, int) { ++n; });
    EXPECT_TRUE(bus.Publish("X", "1", 1));
  }
  EXPECT_TRUE(bus.Publish("X", "2", 1));
  EXPECT_EQ(n, 1);
  const Subscription t = bus.Subscribe<rocklab::block_state_t>(
      "X", [](const std::string&, const rocklab::block_state_t&) {});
  EXPECT_TRUE(bus.Publish("X", "3", 1));  // one byte: does not decode
  EXPECT_EQ(direct.decode_error_count(), 1);
  EXPECT_EQ(bus.decode_error_count(), 1);
}

}  // namespace
}  // namespace rocklab::common
