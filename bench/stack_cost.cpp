// CPU of a stack of blocks against the single block (issue 37: a two-block
// stack under figure 8's sine for 20 s at most 3x the single block's CPU per
// body). Figure 8's block (alpha 0.168 rad, p 3.767 rad/s: 0.173 x 1.022 m,
// 100 kg) alone through rocklab's Housner model with Housner's coefficient,
// as a one-body stack, and under a squat upper block (0.17 x 0.25 m, 20 kg,
// which rocks on it too); best of 5 runs each.
// Usage: rocklab_bench_stack [duration_s]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <functional>

#include "model/excitation.h"
#include "model/rocking_model.h"
#include "model/stack.h"

namespace {

double BestCpu(const std::function<void()>& run) {
  double best = 1e300;
  for (int i = 0; i < 5; ++i) {
    const std::clock_t c0 = std::clock();
    run();
    best = std::min(best, static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC);
  }
  return best;
}

}  // namespace

int main(int argc, char** argv) {
  namespace m = rocklab::model;
  const double duration = argc > 1 ? std::atof(argv[1]) : 20.0;
  const double alpha = 0.168, big_r = 3 * 9.81 / (4 * 3.767 * 3.767);
  const double w = 2 * big_r * std::sin(alpha), h = 2 * big_r * std::cos(alpha);
  const auto sine = m::MakeSine({0.006, 5.0, duration, 0.0});
  m::BlockParams params;
  params.alpha = alpha;
  params.p = 3.767;
  params.mu = 1 - 1.5 * std::pow(std::sin(alpha), 2);
  std::size_t single_events = 0, one_events = 0, two_events = 0, upper_events = 0;
  bool two_overturned = false;
  const double single = BestCpu([&] {
    auto model = m::RockingModel::Create(m::ModelKind::kHousner, params);
    single_events = m::Simulate(*model, *sine, 0.0, 0.0, 0.0, duration, 200.0).events.size();
  });
  m::stack::RunOptions options;
  options.duration_s = duration;
  const m::stack::Stack one({m::stack::Body::Rectangle(w, h, 100.0)});
  const double one_cpu = BestCpu([&] { one_events = m::stack::Simulate(one, *sine, options).events.size(); });
  const m::stack::Stack two({m::stack::Body::Rectangle(w, h, 100.0), m::stack::Body::Rectangle(0.17, 0.45, 20.0)});
  const double two_cpu = BestCpu([&] {
    const auto run = m::stack::Simulate(two, *sine, options);
    two_events = run.events.size();
    upper_events = static_cast<std::size_t>(
        std::count_if(run.events.begin(), run.events.end(), [](const auto& e) { return e.interface == 1; }));
    two_overturned = run.overturned;
  });
  std::printf("figure 8's sine, %.0f s, 200 Hz output, CPU (best of 5):\n", duration);
  std::printf("  single block (Housner model): %.4f s, %zu events\n", single, single_events);
  std::printf("  one-body stack:                %.4f s, %zu events (%.2fx)\n", one_cpu, one_events, one_cpu / single);
  std::printf("  two-block stack:               %.4f s, %zu events (%zu at the interface)%s; per body %.2fx the "
              "single block (target <= 3)\n",
              two_cpu, two_events, upper_events, two_overturned ? ", overturned" : "", two_cpu / 2 / single);
  return 0;
}
