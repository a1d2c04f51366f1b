// What the monitor's state costs: Ingest per message on the LCM thread, a
// full snapshot (a page connecting) and a 100 ms update (one 10 Hz push) at
// a full 60 s window, and the memory after an hour of a 1 kHz pipeline with
// four variants. Run: build/monitor/bench/rocklab_live_state_bench
#include <sys/resource.h>

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "monitor/live_state.h"
#include "rocklab/block_state_t.hpp"
#include "rocklab/comparison_t.hpp"
#include "rocklab/model_state_t.hpp"

namespace rocklab::monitor {
namespace {

struct Payload {
  std::string channel;
  std::vector<std::uint8_t> bytes;
  std::size_t utime_at{8};  // utime follows the 8-byte fingerprint
};

template <class Msg>
Payload Encode(const std::string& channel, const Msg& m) {
  Payload p{channel, std::vector<std::uint8_t>(static_cast<std::size_t>(m.getEncodedSize()))};
  m.encode(p.bytes.data(), 0, static_cast<int>(p.bytes.size()));
  return p;
}

void SetUtime(Payload& p, std::int64_t utime) {
  for (int i = 0; i < 8; ++i) {
    p.bytes[p.utime_at + static_cast<std::size_t>(i)] =
        static_cast<std::uint8_t>(static_cast<std::uint64_t>(utime) >> (56 - 8 * i));
  }
}

// One millisecond of the pipeline: RL_THETA, four RL_MODEL_*, and every
// 50th millisecond four RL_COMPARE_* (20 Hz), as `rocklab run` publishes.
class Pipeline {
 public:
  Pipeline() {
    rocklab::block_state_t theta{};
    theta.theta = 0.01;
    theta_ = Encode("RL_THETA", theta);
    for (const char* name : {"fitted_complex", "fitted_housner", "theory_complex", "theory_housner"}) {
      rocklab::model_state_t m{};
      m.name = name;
      m.model = "complex";
      m.theta = 0.011;
      models_.push_back(Encode(std::string("RL_MODEL_") + name, m));
      rocklab::comparison_t c{};
      c.name = name;
      c.error = 1e-3;
      compares_.push_back(Encode(std::string("RL_COMPARE_") + name, c));
    }
  }
  /// Feeds millisecond k; returns the messages fed.
  int Feed(LiveState& s, std::int64_t k) {
    const std::int64_t utime = k * 1000;
    int n = 0;
    auto feed = [&](Payload& p) {
      SetUtime(p, utime);
      s.Ingest(p.channel, p.bytes.data(), static_cast<int>(p.bytes.size()));
      ++n;
    };
    feed(theta_);
    for (Payload& p : models_) feed(p);
    if (k % 50 == 0) {
      for (Payload& p : compares_) feed(p);
    }
    return n;
  }

 private:
  Payload theta_;
  std::vector<Payload> models_, compares_;
};

long MaxRssKb() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_maxrss;
}

// Per message, with the 60 s window already full (the steady state).
void BM_IngestSteadyState(benchmark::State& state) {
  LiveState s;
  Pipeline p;
  std::int64_t k = 0;
  for (; k < 61'000; ++k) p.Feed(s, k);
  std::int64_t messages = 0;
  for (auto _ : state) messages += p.Feed(s, k++);
  state.SetItemsProcessed(messages);
}
BENCHMARK(BM_IngestSteadyState);

// A page connecting: the whole 60 s window of five series and four
// comparison series as JSON text.
void BM_FullSnapshotJson(benchmark::State& state) {
  LiveState s;
  Pipeline p;
  for (std::int64_t k = 0; k < 61'000; ++k) p.Feed(s, k);
  std::size_t bytes = 0;
  for (auto _ : state) {
    bytes = s.Snapshot().dump().size();
    benchmark::DoNotOptimize(bytes);
  }
  state.counters["json_bytes"] = static_cast<double>(bytes);
}
BENCHMARK(BM_FullSnapshotJson)->Unit(benchmark::kMillisecond);

// One 10 Hz push: the JSON of 100 ms of new data.
void BM_UpdateJson100ms(benchmark::State& state) {
  LiveState s;
  Pipeline p;
  std::int64_t k = 0;
  for (; k < 61'000; ++k) p.Feed(s, k);
  std::size_t bytes = 0;
  for (auto _ : state) {
    state.PauseTiming();
    const std::uint64_t cursor = s.cursor();
    for (int i = 0; i < 100; ++i) p.Feed(s, k++);
    state.ResumeTiming();
    bytes = s.UpdateSince(cursor).dump().size();
    benchmark::DoNotOptimize(bytes);
  }
  state.counters["json_bytes"] = static_cast<double>(bytes);
}
BENCHMARK(BM_UpdateJson100ms)->Unit(benchmark::kMicrosecond);

// An hour of sample clock (3.6 M milliseconds, 18.3 M messages) through a
// 60 s window: the peak RSS before and after says whether anything grows.
void BM_OneHourMemory(benchmark::State& state) {
  for (auto _ : state) {
    LiveState s;
    Pipeline p;
    for (std::int64_t k = 0; k < 120'000; ++k) p.Feed(s, k);  // two windows: every ring full
    const long after_two_minutes = MaxRssKb();
    for (std::int64_t k = 120'000; k < 3'600'000; ++k) p.Feed(s, k);
    state.counters["max_rss_kb_after_2min"] = static_cast<double>(after_two_minutes);
    state.counters["max_rss_kb_after_1h"] = static_cast<double>(MaxRssKb());
  }
}
BENCHMARK(BM_OneHourMemory)->Iterations(1)->Unit(benchmark::kSecond);

}  // namespace
}  // namespace rocklab::monitor

BENCHMARK_MAIN();
