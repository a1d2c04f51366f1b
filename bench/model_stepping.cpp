// rocklab_bench_model_stepping [TRUTH.csv]: the stepping paths of the models
// side by side in one process (docs/performance.md, "What changed" and
// "Stepping across samples in the model node").
// 1. Figure 8 (block 2, 6 mm at 5 Hz, 20 s, outputs at 200 Hz): AdvanceTo
//    (CVODE stopped at every output, 1 ms step cap: simulate's old path)
//    against AdvanceAhead (simulate's path now).
// 2. With TRUTH.csv (a `rocklab synth --truth` file, 1 kHz): its exact table
//    acceleration, and the same with 0.05 m/s^2 of Gaussian noise (seed 1,
//    as an accelerometer gives), fed sample by sample as the model node does:
//    lookahead 0 (Step: stop at every sample, linear in between) and
//    lookahead 32 with the chord and with the centred cubic (SampleWindow,
//    AdvanceAhead up to the window's horizon, the held samples flushed at
//    the end); and the cubic stopping at every sample (horizon = the
//    sample). Accuracy: impacts, and theta against lookahead 0's.
// CPU is the best of three in this process (std::clock) for part 1, one
// run for part 2.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <limits>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "model/rocking_model.h"

namespace {

using namespace rocklab::model;

void Report(const char* what, ModelKind kind, double cpu, const RockingModel& m) {
  int impacts = 0;
  double first = 0, last = 0;
  for (const ModelEvent& e : m.events()) {
    if (e.kind != EventKind::kImpact) continue;
    if (impacts++ == 0) first = e.time_s;
    last = e.time_s;
  }
  const SolverStats s = m.solver_stats();
  std::printf("%-8s %-26s cpu %.4f s  steps %8ld  error-test failures %7ld  impacts %d"
              " (first %.9f s, last %.9f s)\n",
              ToString(kind), what, cpu, s.steps, s.error_test_fails, impacts, first, last);
}

}  // namespace

int main(int argc, char** argv) {
  const auto sine = MakeSine({0.006, 5.0, 20.0, 0.0});
  for (ModelKind kind : {ModelKind::kHousner, ModelKind::kComplex}) {
    for (int ahead = 0; ahead < 2; ++ahead) {
      double best = 1e300;
      std::unique_ptr<RockingModel> m;
      for (int rep = 0; rep < 3; ++rep) {
        m = RockingModel::Create(kind, {0.168, 3.767, 0.942});
        m->Reset(0, 0, 0);
        const std::clock_t c0 = std::clock();
        for (int k = 0; k <= 4000; ++k) {
          const double t = k / 200.0;
          if (ahead) {
            m->AdvanceAhead(t, *sine, std::numeric_limits<double>::infinity());
          } else {
            m->AdvanceTo(t, *sine);
          }
        }
        best = std::min(best, static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC);
      }
      Report(ahead ? "fig 8 AdvanceAhead" : "fig 8 AdvanceTo (old)", kind, best, *m);
    }
  }
  if (argc < 2) return 0;
  std::ifstream in(argv[1]);
  std::string line;
  std::getline(in, line);  // time,theta,theta_dot,table_displacement,table_acceleration,...
  std::vector<double> exact;
  while (std::getline(in, line)) {
    std::stringstream row(line);
    std::string cell;
    for (int c = 0; c <= 4 && std::getline(row, cell, ','); ++c) {
      if (c == 4) exact.push_back(std::stod(cell));
    }
  }
  std::vector<double> noisy = exact;
  std::mt19937 rng(1);
  std::normal_distribution<double> noise(0.0, 0.05);
  for (double& a : noisy) a += noise(rng);
  const int kLookahead = 32;
  for (ModelKind kind : {ModelKind::kHousner, ModelKind::kComplex}) {
    for (int data = 0; data < 2; ++data) {
      const std::vector<double>& accel = data ? noisy : exact;
      std::vector<double> theta0;  // lookahead 0's theta, the reference of the others
      for (int shape = -1; shape < 3; ++shape) {  // -1: lookahead 0 (Step); 2: cubic, stop at samples
        auto m = RockingModel::Create(kind, {0.235, 3.884, 0.937});
        m->Reset(0, 0, 0);
        SampleWindow window(kLookahead + 8, shape >= 1 ? SampleWindow::Shape::kCubic : SampleWindow::Shape::kLinear);
        std::vector<double> theta(accel.size());
        const std::clock_t c0 = std::clock();
        std::size_t next = 0;  // the next sample to step
        for (std::size_t k = 0; k < accel.size(); ++k) {
          const double t = static_cast<double>(k) * 1e-3;
          if (shape < 0) {
            m->Step(t, accel[k]);
            theta[next++] = m->state().theta;
            continue;
          }
          if (!window.Push(t, accel[k])) return 1;
          for (; k - next >= static_cast<std::size_t>(kLookahead) && next <= k; ++next) {
            m->AdvanceAhead(static_cast<double>(next) * 1e-3, window, shape == 2 ? static_cast<double>(next) * 1e-3 : window.horizon_s());
            theta[next] = m->state().theta;
          }
        }
        window.Close();
        for (; next < accel.size(); ++next) {
          m->AdvanceAhead(static_cast<double>(next) * 1e-3, window, shape == 2 ? static_cast<double>(next) * 1e-3 : window.horizon_s());
          theta[next] = m->state().theta;
        }
        const double cpu = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
        double vs_n0 = 0;
        for (std::size_t k = 0; k < theta.size(); ++k) {
          if (shape >= 0) vs_n0 = std::max(vs_n0, std::abs(theta[k] - theta0[k]));
        }
        if (shape < 0) theta0 = theta;
        const std::string what = std::string(data ? "noisy " : "exact ") +
                                 (shape < 0 ? "N=0 Step" : shape == 0 ? "N=32 linear" : shape == 1 ? "N=32 cubic" : "N=32 cubic, stops");
        Report(what.c_str(), kind, cpu, *m);
        std::printf("         %-26s max |theta - N=0| %.3e rad, "
                    "steps/sample %.2f, error-test failures/sample %.2f\n",
                    "", vs_n0, static_cast<double>(m->solver_stats().steps) / accel.size(),
                    static_cast<double>(m->solver_stats().error_test_fails) / accel.size());
      }
    }
  }
  return 0;
}
