// rocklab_bench_model_stepping [TRUTH.csv]: the stepping paths of the models
// side by side in one process (docs/performance.md, "What changed").
// 1. Figure 8 (block 2, 6 mm at 5 Hz, 20 s, outputs at 200 Hz): AdvanceTo
//    (CVODE stopped at every output, 1 ms step cap: simulate's old path)
//    against AdvanceAhead (simulate's path now).
// 2. With TRUTH.csv (a `rocklab synth --truth` file, 1 kHz): its exact table
//    acceleration fed sample by sample, linear in between (Step's old
//    interpolant, through AdvanceTo) against Step (the same interpolant now:
//    a cubic Hermite was tried and reverted, docs/performance.md).
// CPU is the best of three in this process (std::clock).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <limits>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "model/rocking_model.h"

namespace {

using namespace rocklab::model;

// u_g'' linear from (t0, a0) to (t1, a1), held when t1 == t0.
class Chord final : public Forcing {
 public:
  double t0{}, a0{}, t1{}, a1{};
  double TableAcceleration(double t) const override {
    if (!(t1 > t0)) return a1;
    return a0 + (t - t0) / (t1 - t0) * (a1 - a0);
  }
};

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
  std::vector<double> accel;
  while (std::getline(in, line)) {
    std::stringstream row(line);
    std::string cell;
    for (int c = 0; c <= 4 && std::getline(row, cell, ','); ++c) {
      if (c == 4) accel.push_back(std::stod(cell));
    }
  }
  for (ModelKind kind : {ModelKind::kHousner, ModelKind::kComplex}) {
    for (int hermite = 0; hermite < 2; ++hermite) {
      auto m = RockingModel::Create(kind, {0.235, 3.884, 0.937});
      m->Reset(0, 0, 0);
      Chord chord;
      const std::clock_t c0 = std::clock();
      for (std::size_t k = 0; k < accel.size(); ++k) {
        const double t = static_cast<double>(k) * 1e-3;
        if (hermite) {
          m->Step(t, accel[k]);
        } else {
          chord.t0 = k > 0 ? static_cast<double>(k - 1) * 1e-3 : t;
          chord.a0 = k > 0 ? accel[k - 1] : accel[k];
          chord.t1 = t;
          chord.a1 = accel[k];
          m->AdvanceTo(t, chord);
        }
      }
      Report(hermite ? "1 kHz Step" : "1 kHz linear via AdvanceTo", kind,
             static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC, *m);
    }
  }
  return 0;
}
