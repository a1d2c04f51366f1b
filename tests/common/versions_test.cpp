// common/versions.h: each older type read as its successor (seq = kNoSeq),
// WireSeq on every type, ChannelSeqGaps per sender. Oracle: the messages
// and counts are made here by hand.
#include "common/versions.h"

#include <gtest/gtest.h>

#include <vector>

#include "rocklab/block_state2_t.hpp"
#include "rocklab/block_state_t.hpp"
#include "rocklab/raw_frame_t.hpp"
#include "rocklab/table_state_t.hpp"

namespace rocklab::common {
namespace {

template <class Msg>
std::vector<std::uint8_t> Bytes(const Msg& m) {
  std::vector<std::uint8_t> b(static_cast<std::size_t>(m.getEncodedSize()));
  m.encode(b.data(), 0, static_cast<int>(b.size()));
  return b;
}

template <class Decoder, class Msg>
typename Decoder::Message Decode(const Msg& m) {
  const std::vector<std::uint8_t> b = Bytes(m);
  Decoder decode;
  typename Decoder::Message out{};
  out.seq = 99;
  EXPECT_EQ(decode(b.data(), static_cast<int>(b.size()), out), nullptr);
  return out;
}

TEST(Versions, OlderTypesReadAsTheirSuccessorWithNoSeq) {
  rocklab::comparison_t c{};
  c.utime = 5;
  c.name = "fit";
  c.rms_total = 0.25;
  c.valid = true;
  c.samples = 7;
  const rocklab::comparison2_t c2 = Decode<ComparisonDecoder>(c);
  EXPECT_EQ(c2.seq, kNoSeq);
  EXPECT_EQ(c2.utime, 5);
  EXPECT_EQ(c2.name, "fit");
  EXPECT_EQ(c2.rms_total, 0.25);
  EXPECT_TRUE(c2.valid);
  EXPECT_EQ(c2.samples, 7);

  rocklab::event_t e{};
  e.utime = 6;
  e.source = "daq";
  e.kind = rocklab::event_t::GAP;
  e.value = 3;
  e.detail = "gap";
  const rocklab::event2_t e2 = Decode<EventDecoder>(e);
  EXPECT_EQ(e2.seq, kNoSeq);
  EXPECT_EQ(e2.sender, "");
  EXPECT_EQ(e2.source, "daq");
  EXPECT_EQ(e2.kind, +rocklab::event2_t::GAP);
  EXPECT_EQ(e2.value, 3);
  EXPECT_EQ(e2.detail, "gap");

  rocklab::health_t h{};
  h.node = "model";
  h.state = "running";
  h.gaps = 4;
  h.lag_s = 0.5;
  const rocklab::health2_t h2 = Decode<HealthDecoder>(h);
  EXPECT_EQ(h2.seq, kNoSeq);
  EXPECT_EQ(h2.sender, "");
  EXPECT_EQ(h2.node, "model");
  EXPECT_EQ(h2.gaps, 4);
  EXPECT_EQ(h2.lag_s, 0.5);

  rocklab::daq_config_t d{};
  d.rig_name = "rig";
  d.num_channels = 2;
  d.channel_names = {"a", "b"};
  d.channel_units = {"m", "rad"};
  d.channel_sensors = {"x", "y"};
  d.gain = {1, 2};
  d.offset = {0, 1};
  d.mu = 0.9;
  const rocklab::daq_config2_t d2 = Decode<DaqConfigDecoder>(d);
  EXPECT_EQ(d2.seq, kNoSeq);
  EXPECT_EQ(d2.channel_names, d.channel_names);
  EXPECT_EQ(d2.gain, d.gain);
  EXPECT_EQ(d2.mu, 0.9);

  rocklab::model_state_t m1{};
  m1.name = "h";
  m1.theta = 0.1;
  const rocklab::model_state3_t from1 = Decode<ModelStateDecoder>(m1);
  EXPECT_EQ(from1.seq, kNoSeq);
  EXPECT_EQ(from1.theta, 0.1);
  EXPECT_EQ(from1.equations, +rocklab::model_state3_t::EQUATIONS_UNKNOWN);
  rocklab::model_state2_t m2{};
  m2.name = "c";
  m2.l = 0.3;
  m2.equations = rocklab::model_state2_t::EQUATIONS_LIMIT;
  const rocklab::model_state3_t from2 = Decode<ModelStateDecoder>(m2);
  EXPECT_EQ(from2.seq, kNoSeq);
  EXPECT_EQ(from2.l, 0.3);
  EXPECT_EQ(from2.equations, +rocklab::model_state3_t::EQUATIONS_LIMIT);
  rocklab::model_state3_t m3{};
  m3.seq = 12;
  m3.name = "n";
  EXPECT_EQ(Decode<ModelStateDecoder>(m3).seq, 12);
}

// Oracle: every field of a single block's message set by hand to its own
// value, read back from the per-body type's element 0.
TEST(Versions, SingleBodyTypesReadAsThePerBodyTypesWithOneBody) {
  rocklab::block_state_t b{};
  b.utime = 11;
  b.seq = 12;
  b.theta = 0.01;
  b.theta_dot = 0.02;
  b.theta_mirror = 0.03;
  b.theta_camera = 0.04;
  b.sliding = 0.05;
  b.jump = 0.06;
  b.twist = 0.07;
  b.out_of_plane = 0.08;
  b.leds_used = 9;
  b.flags = rocklab::block_state_t::FLAG_JUMP | rocklab::block_state_t::FLAG_NO_MIRROR;
  const rocklab::block_state2_t b2 = Decode<BlockStateBodiesDecoder>(b);
  EXPECT_EQ(b2.utime, 11);
  EXPECT_EQ(b2.seq, 12);
  EXPECT_EQ(b2.nbodies, 1);
  EXPECT_EQ(b2.theta, std::vector<double>{0.01});
  EXPECT_EQ(b2.theta_dot, std::vector<double>{0.02});
  EXPECT_EQ(b2.theta_mirror, std::vector<double>{0.03});
  EXPECT_EQ(b2.theta_camera, std::vector<double>{0.04});
  EXPECT_EQ(b2.sliding, std::vector<double>{0.05});
  EXPECT_EQ(b2.jump, std::vector<double>{0.06});
  EXPECT_EQ(b2.twist, std::vector<double>{0.07});
  EXPECT_EQ(b2.out_of_plane, std::vector<double>{0.08});
  EXPECT_EQ(b2.leds_used, std::vector<std::int32_t>{9});
  EXPECT_EQ(b2.flags, std::vector<std::int32_t>{rocklab::block_state2_t::FLAG_JUMP |
                                                rocklab::block_state2_t::FLAG_NO_MIRROR});

  rocklab::model_state3_t m3{};
  m3.utime = 21;
  m3.seq = 22;
  m3.name = "fit";
  m3.model = "complex";
  m3.theta = 0.1;
  m3.theta_dot = 0.2;
  m3.chi = 0.3;
  m3.psi = 0.4;
  m3.energy = 0.5;
  m3.impact_count = 6;
  m3.regime = rocklab::model_state3_t::REGIME_OVERTURNED;
  m3.alpha = 0.25;
  m3.p = 2.5;
  m3.mu = 0.9;
  m3.l = 0.7;
  m3.equations = rocklab::model_state3_t::EQUATIONS_EQ10;
  const rocklab::model_state4_t m4 = Decode<ModelStateBodiesDecoder>(m3);
  EXPECT_EQ(m4.utime, 21);
  EXPECT_EQ(m4.seq, 22);
  EXPECT_EQ(m4.name, "fit");
  EXPECT_EQ(m4.model, "complex");
  EXPECT_EQ(m4.nbodies, 1);
  EXPECT_EQ(m4.theta, std::vector<double>{0.1});
  EXPECT_EQ(m4.theta_dot, std::vector<double>{0.2});
  EXPECT_EQ(m4.chi, std::vector<double>{0.3});
  EXPECT_EQ(m4.psi, std::vector<double>{0.4});
  EXPECT_EQ(m4.energy, 0.5);
  EXPECT_EQ(m4.impact_count, 6);
  EXPECT_EQ(m4.regime, std::vector<std::int8_t>{rocklab::model_state4_t::REGIME_OVERTURNED});
  EXPECT_EQ(m4.alpha, std::vector<double>{0.25});
  EXPECT_EQ(m4.p, std::vector<double>{2.5});
  EXPECT_EQ(m4.mu, std::vector<double>{0.9});
  EXPECT_EQ(m4.l, 0.7);
  EXPECT_EQ(m4.equations, +rocklab::model_state4_t::EQUATIONS_EQ10);
  EXPECT_EQ(m4.mode, "");

  rocklab::model_state2_t m2{};
  m2.name = "c";
  m2.theta = -0.05;
  m2.equations = rocklab::model_state2_t::EQUATIONS_LIMIT;
  const rocklab::model_state4_t from2 = Decode<ModelStateBodiesDecoder>(m2);
  EXPECT_EQ(from2.seq, kNoSeq);
  EXPECT_EQ(from2.nbodies, 1);
  EXPECT_EQ(from2.theta, std::vector<double>{-0.05});
  EXPECT_EQ(from2.equations, +rocklab::model_state4_t::EQUATIONS_LIMIT);
  rocklab::model_state_t m1{};
  m1.name = "h";
  m1.p = 3.0;
  const rocklab::model_state4_t from1 = Decode<ModelStateBodiesDecoder>(m1);
  EXPECT_EQ(from1.seq, kNoSeq);
  EXPECT_EQ(from1.p, std::vector<double>{3.0});
  EXPECT_EQ(from1.equations, +rocklab::model_state4_t::EQUATIONS_UNKNOWN);
  EXPECT_EQ(from1.mode, "");
}

// One decoder, as a node holds it: a three-body message, then a single
// block's, leaves one element per array (nothing of the three bodies).
TEST(Versions, PerBodyDecoderReadsBothAndKeepsNoStaleBodies) {
  rocklab::model_state4_t three{};
  three.seq = 3;
  three.name = "stack";
  three.nbodies = 3;
  three.theta = {0.1, 0.2, 0.3};
  three.theta_dot = {1, 2, 3};
  three.chi = {0, 0, 0};
  three.psi = {0, 0, 0};
  three.regime = {1, 1, 0};
  three.alpha = {0.2, 0.2, 0.2};
  three.p = {2, 2, 2};
  three.mu = {0.9, 0.9, 0.9};
  three.mode = "rocking-both";
  rocklab::model_state3_t one{};
  one.seq = 4;
  one.theta = 0.5;
  ModelStateBodiesDecoder decode;
  rocklab::model_state4_t out{};
  const std::vector<std::uint8_t> b3 = Bytes(three);
  ASSERT_EQ(decode(b3.data(), static_cast<int>(b3.size()), out), nullptr);
  EXPECT_EQ(out.theta, three.theta);
  EXPECT_EQ(out.mode, "rocking-both");
  const std::vector<std::uint8_t> b1 = Bytes(one);
  ASSERT_EQ(decode(b1.data(), static_cast<int>(b1.size()), out), nullptr);
  EXPECT_EQ(out.seq, 4);
  EXPECT_EQ(out.nbodies, 1);
  EXPECT_EQ(out.theta, std::vector<double>{0.5});
  for (const auto* a : {&out.theta_dot, &out.chi, &out.psi, &out.alpha, &out.p, &out.mu}) EXPECT_EQ(a->size(), 1u);
  EXPECT_EQ(out.regime.size(), 1u);
  EXPECT_EQ(out.mode, "");
  // Cut: refused, with the reason.
  std::vector<std::uint8_t> cut = b3;
  cut.resize(cut.size() - 8);
  EXPECT_NE(decode(cut.data(), static_cast<int>(cut.size()), out), nullptr);
}

TEST(Versions, AnotherTypeIsRefusedWithTheReason) {
  const std::vector<std::uint8_t> b = Bytes(rocklab::block_state_t{});
  EventDecoder decode;
  rocklab::event2_t out{};
  EXPECT_NE(decode(b.data(), static_cast<int>(b.size()), out), nullptr);
}

TEST(Versions, WireSeqReadsEveryCurrentTypeAndNoOlderOne) {
  std::int64_t seq = -1;
  std::string_view sender;
  auto check = [&](const std::vector<std::uint8_t>& b, bool has, std::int64_t want, std::string_view who) {
    seq = -1;
    sender = "x";
    EXPECT_EQ(WireSeq(b.data(), static_cast<int>(b.size()), seq, sender), has);
    if (has) {
      EXPECT_EQ(seq, want);
      EXPECT_EQ(sender, who);
    }
  };
  rocklab::raw_frame_t raw{};
  raw.seq = 1;
  check(Bytes(raw), true, 1, "");
  rocklab::block_state_t theta{};
  theta.seq = 2;
  check(Bytes(theta), true, 2, "");
  rocklab::table_state_t table{};
  table.seq = 3;
  check(Bytes(table), true, 3, "");
  rocklab::comparison2_t c{};
  c.seq = 4;
  check(Bytes(c), true, 4, "");
  rocklab::daq_config2_t d{};
  d.seq = 5;
  check(Bytes(d), true, 5, "");
  rocklab::model_state3_t m{};
  m.seq = 6;
  check(Bytes(m), true, 6, "");
  rocklab::block_state2_t bodies{};
  bodies.seq = 9;
  check(Bytes(bodies), true, 9, "");
  rocklab::model_state4_t m4{};
  m4.seq = 10;
  check(Bytes(m4), true, 10, "");
  rocklab::event2_t e{};
  e.seq = 7;
  e.sender = "compare";
  check(Bytes(e), true, 7, "compare");
  rocklab::health2_t h{};
  h.seq = 8;
  h.sender = "model:fit";
  h.node = "model";
  check(Bytes(h), true, 8, "model:fit");
  check(Bytes(rocklab::comparison_t{}), false, 0, "");
  check(Bytes(rocklab::event_t{}), false, 0, "");
  check(Bytes(rocklab::health_t{}), false, 0, "");
  check(Bytes(rocklab::daq_config_t{}), false, 0, "");
  check(Bytes(rocklab::model_state2_t{}), false, 0, "");
  // Cut inside the sender's length or bytes: not read.
  std::vector<std::uint8_t> cut = Bytes(e);
  cut.resize(30);
  check(cut, false, 0, "");
  cut.resize(26);
  check(cut, false, 0, "");
}

// Two senders interleaved on one channel: 0 1 2 3 and 0 2 3 (1 lost) are one
// gap of one, and neither a step back.
TEST(Versions, ChannelSeqGapsCountsEachSenderApart) {
  ChannelSeqGaps g;
  for (int k = 0; k < 4; ++k) {
    g.Add("daq", k);
    if (k != 1) g.Add("model", k);
  }
  EXPECT_TRUE(g.any);
  EXPECT_EQ(g.gaps, 1);
  EXPECT_EQ(g.missing, 1);
  EXPECT_EQ(g.back, 0);
  EXPECT_EQ(g.senders.size(), 2u);
  // Numbers that step back inside the window (SeqGaps::kWindow) are repeats
  // of that sender's, counted apart, and lose nothing (issue 34: the old
  // rule took them as a restart and counted the next jump as a gap).
  g.Add("daq", 0);
  g.Add("daq", 2);
  EXPECT_EQ(g.back, 2);
  EXPECT_EQ(g.duplicates, 2);
  EXPECT_EQ(g.missing, 1);
  // A late number of the other sender fills its gap in the sums too.
  g.Add("model", 1);
  EXPECT_EQ(g.late, 1);
  EXPECT_EQ(g.missing, 0);
  EXPECT_EQ(g.gaps, 0);
  // Beyond kMaxSenders: counted, not told apart.
  for (std::size_t i = 0; i < ChannelSeqGaps::kMaxSenders; ++i) g.Add("n" + std::to_string(i), 0);
  EXPECT_EQ(g.senders.size(), ChannelSeqGaps::kMaxSenders);
  EXPECT_EQ(g.unkeyed, 2);
}

}  // namespace
}  // namespace rocklab::common
