#include "common/versions.h"

#include "rocklab/band_comparison_t.hpp"
#include "rocklab/block_state_t.hpp"
#include "rocklab/comparison3_t.hpp"
#include "rocklab/model_band_t.hpp"
#include "rocklab/raw_frame_t.hpp"
#include "rocklab/table_state_t.hpp"

namespace rocklab::common {

namespace {
// An older type's fields are the ones its field table lists; the successor
// has each of them under the same name.
template <class In, class Out, class Table>
void CopyOlderFields(const In& in, Out& out, Table table) {
  FieldCopier<In, Out> copier{in, out};
  table(copier);
}
}  // namespace

void Upgrade(const rocklab::comparison_t& in, rocklab::comparison2_t& out) {
  CopyOlderFields(in, out, [](auto& c) { ComparisonFields<rocklab::comparison_t>(c); });
  out.seq = kNoSeq;
}

void Upgrade(const rocklab::daq_config_t& in, rocklab::daq_config2_t& out) {
  CopyOlderFields(in, out, [](auto& c) { DaqConfigFields<rocklab::daq_config_t>(c); });
  out.seq = kNoSeq;
}

void Upgrade(const rocklab::event_t& in, rocklab::event2_t& out) {
  CopyOlderFields(in, out, [](auto& c) { EventFields<rocklab::event_t>(c); });
  out.seq = kNoSeq;
  out.sender.clear();
}

void Upgrade(const rocklab::health_t& in, rocklab::health2_t& out) {
  CopyOlderFields(in, out, [](auto& c) { HealthFields<rocklab::health_t>(c); });
  out.seq = kNoSeq;
  out.sender.clear();
}

void Upgrade(const rocklab::block_state_t& in, rocklab::block_state2_t& out) {
  CopyOlderFields(in, out, [](auto& c) { BlockStateFields<rocklab::block_state_t>(c); });
  out.nbodies = 1;
}

void Upgrade(const rocklab::model_state3_t& in, rocklab::model_state4_t& out) {
  CopyOlderFields(in, out, [](auto& c) { ModelStateFields<rocklab::model_state3_t>(c); });
  out.nbodies = 1;
  out.mode.clear();
}

void Upgrade(const rocklab::model_state2_t& in, rocklab::model_state4_t& out) {
  CopyOlderFields(in, out, [](auto& c) { ModelStateFields<rocklab::model_state2_t>(c); });
  out.seq = kNoSeq;
  out.nbodies = 1;
  out.mode.clear();
}

void Upgrade(const rocklab::model_state_t& in, rocklab::model_state4_t& out) {
  CopyOlderFields(in, out, [](auto& c) { ModelStateFields<rocklab::model_state_t>(c); });
  out.seq = kNoSeq;
  out.equations = rocklab::model_state4_t::EQUATIONS_UNKNOWN;
  out.nbodies = 1;
  out.mode.clear();
}

void BodyOf(const rocklab::model_state4_t& in, std::size_t k, rocklab::model_state3_t& out) {
  out.utime = in.utime;
  out.seq = in.seq;
  out.name = in.name;
  out.model = in.model;
  out.theta = in.theta[k];
  out.theta_dot = in.theta_dot[k];
  out.chi = in.chi[k];
  out.psi = in.psi[k];
  out.energy = in.energy;
  out.impact_count = in.impact_count;
  out.regime = in.regime[k];
  out.alpha = in.alpha[k];
  out.p = in.p[k];
  out.mu = in.mu[k];
  out.l = in.l;
  out.equations = in.equations;
}

namespace {
template <class M>
void UpgradeModel(const M& in, rocklab::model_state3_t& out) {
  CopyModelStateFields(in, out);
  out.seq = kNoSeq;
}

std::int64_t Be64(const std::uint8_t* p) {
  std::uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v = (v << 8) | p[i];
  return static_cast<std::int64_t>(v);
}
}  // namespace

void Upgrade(const rocklab::model_state_t& in, rocklab::model_state3_t& out) {
  UpgradeModel(in, out);
  out.equations = rocklab::model_state3_t::EQUATIONS_UNKNOWN;
}

void Upgrade(const rocklab::model_state2_t& in, rocklab::model_state3_t& out) {
  UpgradeModel(in, out);
  out.equations = in.equations;
}

bool WireSeq(const void* data, int size, std::int64_t& seq, std::string_view& sender) {
  // fingerprint (8), utime (8), seq (8)
  if (data == nullptr || size < 24) return false;
  static const std::int64_t kSingle[] = {
      static_cast<std::int64_t>(rocklab::raw_frame_t::getHash()),
      static_cast<std::int64_t>(rocklab::block_state_t::getHash()),
      static_cast<std::int64_t>(rocklab::block_state2_t::getHash()),
      static_cast<std::int64_t>(rocklab::table_state_t::getHash()),
      static_cast<std::int64_t>(rocklab::comparison2_t::getHash()),
      static_cast<std::int64_t>(rocklab::comparison3_t::getHash()),
      static_cast<std::int64_t>(rocklab::daq_config2_t::getHash()),
      static_cast<std::int64_t>(rocklab::model_state3_t::getHash()),
      static_cast<std::int64_t>(rocklab::model_state4_t::getHash()),
      static_cast<std::int64_t>(rocklab::model_band_t::getHash()),
      static_cast<std::int64_t>(rocklab::band_comparison_t::getHash())};
  static const std::int64_t kSenders[] = {static_cast<std::int64_t>(rocklab::event2_t::getHash()),
                                          static_cast<std::int64_t>(rocklab::health2_t::getHash())};
  const auto* b = static_cast<const std::uint8_t*>(data);
  const std::int64_t fingerprint = Be64(b);
  for (std::int64_t h : kSingle) {
    if (h == fingerprint) {
      seq = Be64(b + 16);
      sender = {};
      return true;
    }
  }
  for (std::int64_t h : kSenders) {
    if (h != fingerprint) continue;
    // The string after seq: int32 length including the NUL, then the bytes.
    if (size < 28) return false;
    const std::int64_t len = static_cast<std::int32_t>((std::uint32_t{b[24]} << 24) | (std::uint32_t{b[25]} << 16) |
                                                       (std::uint32_t{b[26]} << 8) | std::uint32_t{b[27]});
    if (len < 1 || len > size - 28) return false;
    seq = Be64(b + 16);
    sender = std::string_view(reinterpret_cast<const char*>(b + 28), static_cast<std::size_t>(len - 1));
    return true;
  }
  return false;
}

void ChannelSeqGaps::Add(std::string_view sender, std::int64_t seq) {
  sender = sender.substr(0, kMaxSenderBytes);  // bounded memory whatever arrives
  SeqGaps* s = nullptr;
  for (auto& [name, gaps_of] : senders) {
    if (name == sender) s = &gaps_of;
  }
  if (s == nullptr) {
    if (senders.size() >= kMaxSenders) {
      ++unkeyed;
      return;
    }
    senders.emplace_back(std::string(sender), SeqGaps{});
    s = &senders.back().second;
  }
  const SeqGaps::Counts before = s->counts();
  s->Add(seq);
  any = true;
  // Each sender's counts saturate (SeqGaps); so do their sums.
  SeqGaps::AddChange(*this, before, s->counts());
}

}  // namespace rocklab::common
