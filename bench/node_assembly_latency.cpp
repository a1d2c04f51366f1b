// rocklab_bench_node_assembly [DRUMS] [AMPLITUDE_MPS2]: the model node
// running a column of DRUMS (default 5) equal drums live at 1 kHz, its
// latency per table sample (docs/performance.md, "An assembly in the model
// node").
//
// The column: drums of 0.4 m x 0.5 m, 200 kg each, the angular momentum
// rule at every joint. The table: 6 s of a 1.5 Hz sine of AMPLITUDE
// (default 2.0 m/s^2; the column lifts off at 1.57 m/s^2) and 4 s still,
// as RL_TABLE samples at 1 kHz into a ModelNode on a DirectBus (one
// variant, one thread; its model_state4_t encoded and published, nobody
// subscribed), after an RL_THETA at rest. Per sample, HandleTable's wall
// time (steady_clock) and the thread's CPU time (CLOCK_THREAD_CPUTIME_ID,
// which a loaded machine's preemption does not inflate): their median,
// p99, p99.9 and maximum, over all samples and over those where the
// column moves (an interface open, nothing overturned yet); beside it the
// same record through stack::Simulate (simulate --assembly's path, Adams
// across the samples). Three runs of the node, each printed; a failed
// integration voids the figures (exit 1).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <string>
#include <vector>

#include "common/direct_bus.h"
#include "model/excitation.h"
#include "model/model_node.h"
#include "model/stack.h"
#include "model/variant.h"
#include "rocklab/block_state_t.hpp"
#include "rocklab/table_state_t.hpp"

namespace {

using namespace rocklab::model;

double ThreadCpuNs() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e9 + static_cast<double>(ts.tv_nsec);
}

struct Quantiles {
  double p50, p99, p999, max;
};

Quantiles Of(std::vector<double> v) {
  if (v.empty()) return {0, 0, 0, 0};
  std::sort(v.begin(), v.end());
  auto at = [&](double q) { return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))]; };
  return {at(0.5), at(0.99), at(0.999), v.back()};
}

}  // namespace

int main(int argc, char** argv) {
  const int drums = argc > 1 ? std::atoi(argv[1]) : 5;
  const double amplitude = argc > 2 ? std::atof(argv[2]) : 2.0;
  if (drums < 1 || drums > stack::kMaxBodies || !(amplitude >= 0)) {
    std::fprintf(stderr, "usage: rocklab_bench_node_assembly [DRUMS 1..%d] [AMPLITUDE_MPS2 >= 0]\n", stack::kMaxBodies);
    return 2;
  }
  std::vector<stack::Body> bodies;
  std::vector<std::string> names;
  for (int k = 0; k < drums; ++k) {
    bodies.push_back(stack::Body::Rectangle(0.4, 0.5, 200.0));
    names.push_back("drum" + std::to_string(k + 1));
  }
  VariantSpec spec;
  spec.name = "drums";
  spec.kind = ModelKind::kHousner;
  spec.params = {0.2, 3.0, 0.9};  // the row summary only; the stack is what runs
  spec.stack = stack::Stack(bodies);
  spec.body_names = names;
  spec.params_source = "bench";
  ModelNodeConfig config;
  config.variants.push_back(spec);

  constexpr int kSamples = 10000;  // 10 s at 1 kHz
  const double pi = 3.141592653589793;
  std::vector<double> times, accels;
  for (int k = 0; k < kSamples; ++k) {
    times.push_back(k * 1e-3);
    accels.push_back(times.back() < 6.0 ? amplitude * std::sin(2 * pi * 1.5 * times.back()) : 0.0);
  }
  {
    // The same record through simulate --assembly's path (stack::Simulate,
    // Adams across the samples), for its outcome and CPU beside the node's.
    stack::RunOptions ro;
    ro.rate_hz = 1000.0;
    ro.duration_s = (kSamples - 1) * 1e-3;
    const SampledAcceleration record(times, accels);
    const std::clock_t c0 = std::clock();
    try {
      const stack::Run r = stack::Simulate(*spec.stack, record, ro);
      std::printf("simulate --assembly's path: %zu events, %ld steps, overturned %s, CPU %.3f s\n", r.events.size(),
                  r.steps, r.overturned ? "yes" : "no", static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC);
    } catch (const std::exception& e) {
      std::printf("simulate --assembly's path failed: %s\n", e.what());
    }
  }
  for (int run = 0; run < 3; ++run) {
    rocklab::common::DirectBus bus;
    ModelNode node(config, bus);
    const std::int64_t t0 = 1'700'000'000'000'000;
    rocklab::block_state_t theta{};
    theta.utime = t0;
    node.HandleTheta(theta);
    std::vector<double> wall_all, cpu_all, wall_rocking, cpu_rocking;
    long several = 0;  // moving samples with two or more interfaces open
    int overturn_sample = -1;
    wall_all.reserve(kSamples);
    cpu_all.reserve(kSamples);
    const std::string rest(static_cast<std::size_t>(drums), 'C');
    for (int k = 0; k < kSamples; ++k) {
      rocklab::table_state_t m{};
      m.utime = t0 + 1000 * static_cast<std::int64_t>(k);
      m.seq = k;
      m.acceleration = accels[static_cast<std::size_t>(k)];
      const double c0 = ThreadCpuNs();
      const auto w0 = std::chrono::steady_clock::now();
      node.HandleTable(m);
      const auto w1 = std::chrono::steady_clock::now();
      const double c1 = ThreadCpuNs();
      const double wall = std::chrono::duration<double, std::nano>(w1 - w0).count();
      wall_all.push_back(wall);
      cpu_all.push_back(c1 - c0);
      const rocklab::model_state4_t& now = node.latest_bodies(0);
      const std::string& mode = now.mode;
      const bool fallen = std::any_of(now.regime.begin(), now.regime.end(), [](std::int8_t r) {
        return r == rocklab::model_state4_t::REGIME_OVERTURNED;
      });
      if (fallen && overturn_sample < 0) overturn_sample = k;
      // Moving: some interface open and nothing overturned (then the state is frozen).
      if (mode != rest && !fallen) {
        several += std::count(mode.begin(), mode.end(), 'C') <= drums - 2;
        wall_rocking.push_back(wall);
        cpu_rocking.push_back(c1 - c0);
      }
    }
    const rocklab::model_state4_t& last = node.latest_bodies(0);
    const Quantiles wa = Of(wall_all), ca = Of(cpu_all), wr = Of(wall_rocking), cr = Of(cpu_rocking);
    if (node.failures() > 0) {
      std::printf("run %d: the stack's integration failed (logged above): figures not valid\n", run + 1);
      return 1;
    }
    std::printf("run %d: %d drums, %d samples, %zu moving (%ld with two or more interfaces open), impacts %d, "
                "overturned at sample %d (-1: never), final mode %s\n",
                run + 1, drums, kSamples, wall_rocking.size(), several, last.impact_count, overturn_sample,
                last.mode.c_str());
    std::printf("  all samples     wall us: p50 %.2f p99 %.2f p99.9 %.2f max %.2f | cpu us: p50 %.2f p99 %.2f p99.9 %.2f max %.2f\n",
                wa.p50 / 1e3, wa.p99 / 1e3, wa.p999 / 1e3, wa.max / 1e3, ca.p50 / 1e3, ca.p99 / 1e3, ca.p999 / 1e3,
                ca.max / 1e3);
    std::printf("  moving samples  wall us: p50 %.2f p99 %.2f p99.9 %.2f max %.2f | cpu us: p50 %.2f p99 %.2f p99.9 %.2f max %.2f\n",
                wr.p50 / 1e3, wr.p99 / 1e3, wr.p999 / 1e3, wr.max / 1e3, cr.p50 / 1e3, cr.p99 / 1e3, cr.p999 / 1e3,
                cr.max / 1e3);
  }
  return 0;
}
