// common/versions.h: each older type read as its successor (seq = kNoSeq),
// WireSeq on every type, ChannelSeqGaps per sender. Oracle: the messages
// and counts are made here by hand.
#include "common/versions.h"

#include <gtest/gtest.h>

#include <vector>

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
