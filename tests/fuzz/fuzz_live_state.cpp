// Fuzz target: the monitor's state ingest. The input is a sequence of
// records; each record's first byte picks the channel (RL_THETA,
// RL_MODEL_a/b, RL_COMPARE_a, RL_EVENT, RL_HEALTH, RL_DAQ_CONFIG, another
// channel) and its second byte the form:
//   even: the next bytes (length in the third byte) are decoded as they are
//         (raw bytes through the generated decoders);
//   odd:  a well-formed message of the channel's type is built from the next
//         bytes (utime, values, flags, kind, strings) and encoded, so that
//         decoded messages with hostile fields (utime near INT64_MIN, NaN,
//         huge counts, binary text) reach the state.
// After each record the snapshot and the update since the last cursor are
// made and serialised as the server does.
// Invariants: Ingest and the JSON never throw; the cursor never goes back;
// every time in the snapshot is finite.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "monitor/live_state.h"
#include "rocklab/block_state_t.hpp"
#include "rocklab/comparison2_t.hpp"
#include "rocklab/daq_config2_t.hpp"
#include "rocklab/event2_t.hpp"
#include "rocklab/health2_t.hpp"
#include "rocklab/model_state_t.hpp"
#include "tests/fuzz/fuzz_util.h"

namespace {

// Reads fields off the input, zeros once it is used up.
class Bytes {
 public:
  Bytes(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  bool empty() const { return pos_ >= size_; }
  std::uint8_t Byte() { return pos_ < size_ ? data_[pos_++] : 0; }
  template <class T>
  T Get() {
    T v{};
    std::uint8_t b[sizeof(T)] = {};
    for (auto& x : b) x = Byte();
    std::memcpy(&v, b, sizeof v);
    return v;
  }
  std::string Text() {
    const std::size_t n = Byte() % 24;
    std::string s;
    for (std::size_t i = 0; i < n; ++i) s.push_back(static_cast<char>(Byte()));
    return s;
  }
  std::vector<std::uint8_t> Raw() {
    const std::size_t n = Byte();
    std::vector<std::uint8_t> v;
    for (std::size_t i = 0; i < n && !empty(); ++i) v.push_back(Byte());
    return v;
  }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_{0};
};

template <class Msg>
std::vector<std::uint8_t> Encode(const Msg& m) {
  std::vector<std::uint8_t> b(static_cast<std::size_t>(m.getEncodedSize()));
  if (m.encode(b.data(), 0, static_cast<int>(b.size())) < 0) rocklab::fuzz::Violated("encode");
  return b;
}

std::vector<std::uint8_t> Build(int kind, Bytes& in, std::string& channel) {
  switch (kind) {
    case 0: {
      channel = "RL_THETA";
      rocklab::block_state_t m{};
      m.utime = in.Get<std::int64_t>();
      m.seq = in.Get<std::int64_t>();
      m.theta = in.Get<double>();
      m.flags = in.Get<std::int32_t>();
      return Encode(m);
    }
    case 1:
    case 2: {
      channel = kind == 1 ? "RL_MODEL_a" : "RL_MODEL_b";
      rocklab::model_state_t m{};
      m.utime = in.Get<std::int64_t>();
      m.name = in.Text();
      m.model = in.Text();
      m.theta = in.Get<double>();
      m.alpha = in.Get<double>();
      m.p = in.Get<double>();
      m.mu = in.Get<double>();
      m.impact_count = in.Get<std::int32_t>();
      m.regime = in.Get<std::int8_t>();
      return Encode(m);
    }
    case 3: {
      channel = "RL_COMPARE_a";
      rocklab::comparison2_t m{};
      m.utime = in.Get<std::int64_t>();
      m.name = in.Text();
      m.error = in.Get<double>();
      m.rms_window = in.Get<double>();
      m.nrms = in.Get<double>();
      m.valid = (in.Byte() & 1) != 0;
      m.samples = in.Get<std::int64_t>();
      return Encode(m);
    }
    case 4: {
      channel = "RL_EVENT";
      rocklab::event2_t m{};
      m.utime = in.Get<std::int64_t>();
      m.source = in.Text();
      m.kind = in.Get<std::int8_t>();
      m.value = in.Get<double>();
      m.detail = in.Text();
      return Encode(m);
    }
    case 5: {
      channel = "RL_HEALTH";
      rocklab::health2_t m{};
      m.utime = in.Get<std::int64_t>();
      m.node = in.Text();
      m.state = in.Text();
      m.count_in = in.Get<std::int64_t>();
      m.dropped = in.Get<std::int64_t>();
      m.lag_s = in.Get<double>();
      return Encode(m);
    }
    default: {
      channel = "RL_DAQ_CONFIG";
      rocklab::daq_config2_t m{};
      m.utime = in.Get<std::int64_t>();
      m.rig_name = in.Text();
      m.sample_rate_hz = in.Get<double>();
      m.num_channels = in.Byte() % 4;
      for (int i = 0; i < m.num_channels; ++i) {
        m.channel_names.push_back(in.Text());
        m.channel_units.push_back(in.Text());
        m.channel_sensors.push_back(in.Text());
        m.gain.push_back(in.Get<double>());
        m.offset.push_back(in.Get<double>());
      }
      return Encode(m);
    }
  }
}

const char* const kChannels[] = {"RL_THETA",  "RL_MODEL_a", "RL_MODEL_b",    "RL_COMPARE_a",
                                 "RL_EVENT",  "RL_HEALTH",  "RL_DAQ_CONFIG", "RL_OTHER"};

void CheckTimes(const nlohmann::json& j) {
  if (j.is_number_float() && !std::isfinite(j.get<double>())) return;  // values may be NaN; times are checked below
  if (j.is_object()) {
    for (const auto& [key, value] : j.items()) {
      if (key == "t" && value.is_array()) {
        for (const auto& t : value) {
          if (t.is_number() && !std::isfinite(t.get<double>())) rocklab::fuzz::Violated("time not finite");
        }
      }
      CheckTimes(value);
    }
  } else if (j.is_array()) {
    for (const auto& v : j) CheckTimes(v);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  // Small rings, so that a run spends its time in the ingest and the JSON
  // rather than in allocating 60 s of series per input.
  rocklab::monitor::LiveOptions options;
  options.window_s = 2.0;
  options.series_rate_hz = 50.0;
  options.max_events = 16;
  options.max_intervals = 16;
  options.max_variants = 4;
  options.max_nodes = 4;
  options.max_channels = 8;
  rocklab::monitor::LiveState state(options);
  Bytes in(data, size);
  std::uint64_t cursor = 0;
  int records = 0;
  while (!in.empty() && records++ < 32) {
    const int kind = in.Byte() % 8;
    const bool build = (in.Byte() & 1) != 0;
    std::string channel = kChannels[kind];
    std::vector<std::uint8_t> bytes;
    if (build && kind < 7) {
      bytes = Build(kind, in, channel);
    } else {
      bytes = in.Raw();
    }
    state.Ingest(channel, bytes.data(), static_cast<int>(bytes.size()));
    const nlohmann::json update = state.UpdateSince(cursor);
    const std::uint64_t next = update.at("cursor").get<std::uint64_t>();
    if (next < cursor) rocklab::fuzz::Violated("cursor went back");
    cursor = next;
    (void)update.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  }
  const nlohmann::json snap = state.Snapshot();
  CheckTimes(snap);
  (void)snap.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  return 0;
}
