// rocklab_bench_forced_steps [--model housner|complex] [--rtol R] [--l L]
//   [--stride K] [--from-ms T] [--reps N]
// Where the forced trajectory likelihood's model run spends its CVODE steps
// (docs/performance.md, "The forced complex likelihood"): the bench
// posterior's forced record (block 1 at rest under figure 7's Hanning sine,
// 6 mm at 3.3 Hz, 7 s; its table acceleration sampled at 1 kHz and linear
// between samples, as the likelihood sees it), the model run at atol 1e-10
// and output every K-th sample as the likelihood runs it. Prints the
// process CPU per run (mean of N), the solver's counters, the steps taken
// in the 1 ms intervals that hold an impact, and theta against the same
// model at rtol 1e-12 output at every sample: largest difference and the
// log-likelihood shift sum(d^2) / (2 sigma^2) at the record's noise (0.02
// deg). --from-ms T starts the run at rest at T ms instead of 0 (what the
// likelihood's rest skip does).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <string>
#include <vector>

#include "model/excitation.h"
#include "model/rocking_model.h"

namespace {

using namespace rocklab::model;

double ProcessCpuS() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

}  // namespace

int main(int argc, char** argv) {
  std::string model_name = "complex";
  double rtol = 1e-6, l = kDefaultL;
  int stride = 1, from_ms = 0, reps = 20;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) {
      std::fprintf(stderr, "%s needs a value\n", a.c_str());
      return 2;
    }
    const char* v = argv[++i];
    if (a == "--model") {
      model_name = v;
    } else if (a == "--rtol") {
      rtol = std::atof(v);
    } else if (a == "--l") {
      l = std::atof(v);
    } else if (a == "--stride") {
      stride = std::max(1, std::atoi(v));
    } else if (a == "--from-ms") {
      from_ms = std::max(0, std::atoi(v));
    } else if (a == "--reps") {
      reps = std::max(1, std::atoi(v));
    } else {
      std::fprintf(stderr, "unknown option %s\n", a.c_str());
      return 2;
    }
  }
  const ModelKind kind = ParseModelKind(model_name);
  const BlockParams truth{0.235, 3.884, 0.937};
  SineSpec s;
  s.amplitude_m = 0.006;
  s.frequency_hz = 3.3;
  s.duration_s = 4.0;
  s.start_s = 0.5;
  const auto hanning = MakeHanningSine(s);
  constexpr int kSamples = 7000;  // 7 s at 1 kHz
  std::vector<double> t, acc;
  for (int k = 0; k <= kSamples; ++k) {
    t.push_back(k / 1000.0);
    acc.push_back(hanning->TableAcceleration(t.back()));
  }
  const SampledAcceleration table(t, acc);
  ModelOptions ref_options;
  ref_options.rtol = 1e-12;
  ref_options.atol = 1e-12;
  ref_options.l = l;
  auto ref = RockingModel::Create(kind, truth, ref_options);
  ref->Reset(0.0, 0.0, 0.0);
  std::vector<double> theta_ref(t.size());
  for (std::size_t k = 0; k < t.size(); ++k) {
    ref->AdvanceAhead(t[k], table, INFINITY);
    theta_ref[k] = ref->state().theta;
  }
  ModelOptions mo;
  mo.rtol = rtol;
  mo.atol = 1e-10;
  mo.l = l;
  // One run with the counters.
  auto m = RockingModel::Create(kind, truth, mo);
  m->Reset(from_ms / 1000.0, 0.0, 0.0);
  long impact_steps = 0, impact_intervals = 0, impacts = 0, before = 0;
  std::size_t seen = 0;
  double worst = 0.0, ss = 0.0;
  for (int k = from_ms; k <= kSamples; k += stride) {
    m->AdvanceAhead(t[static_cast<std::size_t>(k)], table, INFINITY);
    const long steps = m->solver_stats().steps;
    bool impact = false;
    for (; seen < m->events().size(); ++seen) impact |= m->events()[seen].kind == EventKind::kImpact;
    if (impact) {
      impact_steps += steps - before;
      ++impact_intervals;
    }
    before = steps;
    const double d = m->state().theta - theta_ref[static_cast<std::size_t>(k)];
    worst = std::max(worst, std::abs(d));
    ss += d * d;
  }
  for (const ModelEvent& e : m->events()) impacts += e.kind == EventKind::kImpact;
  const SolverStats st = m->solver_stats();
  // CPU: the same run, reps times.
  double sink = 0.0;
  const double c0 = ProcessCpuS();
  for (int r = 0; r < reps; ++r) {
    auto run = RockingModel::Create(kind, truth, mo);
    run->Reset(from_ms / 1000.0, 0.0, 0.0);
    for (int k = from_ms; k <= kSamples; k += stride) {
      run->AdvanceAhead(t[static_cast<std::size_t>(k)], table, INFINITY);
      sink += run->state().theta;
    }
  }
  const double cpu = (ProcessCpuS() - c0) / reps;
  const double sigma = 0.02 * 3.14159265358979 / 180.0;
  std::printf("%s, rtol %g, l %g, stride %d, from %d ms: %.2f ms CPU per run (%d runs, sum %.3g)\n", model_name.c_str(),
              rtol, l, stride, from_ms, cpu * 1e3, reps, sink);
  std::printf("  steps %ld, rhs %ld, error-test failures %ld; %ld impacts; steps in the %ld 1 ms intervals with an "
              "impact %ld, elsewhere %ld\n",
              st.steps, st.rhs_evals, st.error_test_fails, impacts, impact_intervals, impact_steps,
              st.steps - impact_steps);
  std::printf("  theta against rtol 1e-12 at the outputs: max %.3g rad, sum d^2 / (2 sigma^2) %.3g\n", worst,
              ss / (2 * sigma * sigma));
  return 0;
}
