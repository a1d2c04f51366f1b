// rocklab_bench_posterior [--case free|forced|impacts] [--model housner|complex]
//   [--walkers W] [--steps S] [--threads T] [--rtol R] [--integrator adams|rk]
//   [--stride K] [--seed N] [--accuracy] [--cvode]
// Wall clock of `rocklab fit --posterior`'s sampler on synthetic records
// (docs/performance.md, "Posterior"):
//   free:    block 1 (0.247 x 1.0 m, truth alpha 0.235, p 3.884, mu 0.937,
//            Table 2), held at 0.1 rad for 0.5 s, released, 10 s in all at
//            1 kHz with 0.02 deg of Gaussian noise; trajectory likelihood.
//   impacts: the same record, impacts likelihood.
//   forced:  the same block at rest under a Hanning sine of 6 mm at 3.3 Hz
//            (figure 7), 7 s at 1 kHz, table at 1 kHz, same noise;
//            trajectory likelihood.
// The records are rocklab's own model at rtol 1e-10 (this measures speed;
// the oracles of the posterior are in the tests). --accuracy also prints
// theta of one likelihood run at the chosen rtol/integrator against rtol
// 1e-10 (what the looser model costs). --cvode: free Housner through the
// CVODE model (PosteriorOptions::free_rk4 off) instead of SampleFreeHousner.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <random>
#include <string>

#include "model/excitation.h"
#include "model/posterior.h"
#include "model/rocking_model.h"

namespace {

using namespace rocklab::model;

RockingRecord Synthetic(bool forced, ModelKind kind, double duration_s) {
  const BlockParams truth{0.235, 3.884, 0.937};
  ModelOptions mo;
  mo.rtol = 1e-10;
  auto model = RockingModel::Create(kind, truth, mo);
  RockingRecord r;
  r.source = forced ? "synthetic-forced" : "synthetic-free";
  std::mt19937 rng(1);
  std::normal_distribution<double> noise(0.0, 0.02 * 3.14159265358979 / 180.0);
  const double rate = 1000.0;
  const auto n = static_cast<long>(duration_s * rate);
  std::unique_ptr<Excitation> table;
  if (forced) {
    SineSpec s;
    s.amplitude_m = 0.006;
    s.frequency_hz = 3.3;
    s.duration_s = 4.0;
    s.start_s = 0.5;
    table = MakeHanningSine(s);
    model->Reset(0.0, 0.0, 0.0);
  } else {
    model->Reset(0.5, 0.1, 0.0);
  }
  const NoTableMotion none;
  for (long k = 0; k <= n; ++k) {
    const double t = static_cast<double>(k) / rate;
    double theta = 0.1;
    if (forced || t > 0.5) {
      model->AdvanceAhead(t, forced ? static_cast<const Forcing&>(*table) : none, INFINITY);
      theta = model->state().theta;
    }
    r.time_s.push_back(t);
    r.theta.push_back(theta + noise(rng));
    r.line.push_back(k + 2);
    if (forced) {
      r.table_time_s.push_back(t);
      r.table_accel_mps2.push_back(table->TableAcceleration(t));
    }
  }
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  std::string which = "free", model_name = "housner", integrator = "adams";
  PosteriorOptions o;
  o.fit.geometry = FitGeometry{0.247, 1.0, 0.0};
  bool accuracy = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "%s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--case") {
      which = next();
    } else if (a == "--model") {
      model_name = next();
    } else if (a == "--walkers") {
      o.sampler.walkers = std::stoi(next());
    } else if (a == "--steps") {
      o.sampler.steps = std::stoi(next());
    } else if (a == "--threads") {
      o.sampler.threads = std::stoi(next());
    } else if (a == "--rtol") {
      o.rtol = std::stod(next());
    } else if (a == "--integrator") {
      integrator = next();
    } else if (a == "--stride") {
      o.output_stride = std::stoi(next());
    } else if (a == "--seed") {
      o.sampler.seed = std::stoull(next());
    } else if (a == "--accuracy") {
      accuracy = true;
    } else if (a == "--cvode") {
      o.free_rk4 = false;
    } else {
      std::fprintf(stderr, "unknown option %s\n", a.c_str());
      return 2;
    }
  }
  const bool forced = which == "forced";
  o.method = which == "impacts" ? FitMethod::kImpacts : FitMethod::kTrajectory;
  o.model = ParseModelKind(model_name);
  o.integrator = integrator == "rk" ? Integrator::kRungeKutta : Integrator::kAdams;
  const RockingRecord record = Synthetic(forced, o.model, forced ? 7.0 : 10.0);
  const auto t0 = std::chrono::steady_clock::now();
  const PosteriorProblem problem(record, o);
  const double setup = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (accuracy) {
    // One likelihood run at the chosen tolerance against rtol 1e-10, at the
    // start point: the rms of the theta difference is in the log likelihood
    // as a shift of ss / (2 sigma^2).
    PosteriorOptions tight = o;
    tight.rtol = 1e-10;
    tight.integrator = Integrator::kAdams;
    tight.output_stride = 1;
    tight.free_rk4 = false;
    const PosteriorProblem reference(record, tight, &problem.point());
    const Eigen::VectorXd x = problem.Start();
    std::printf("start point (sampled coordinates):");
    for (Eigen::Index i = 0; i < x.size(); ++i) std::printf(" %s %.9g", problem.names()[static_cast<std::size_t>(i)].c_str(), x(i));
    std::printf("\n");
    const auto a0 = std::chrono::steady_clock::now();
    const double lp = problem.LogPosterior(x);
    const double run = std::chrono::duration<double>(std::chrono::steady_clock::now() - a0).count();
    const double lp_ref = reference.LogPosterior(x);
    std::printf("one likelihood run: %.2f ms; log posterior %.6f against %.6f at rtol 1e-10 (difference %.3g)\n",
                run * 1e3, lp, lp_ref, lp - lp_ref);
    Eigen::VectorXd truth = x;
    truth(0) = 0.235;
    truth(1) = 3.884;
    truth(2) = 0.937;
    if (o.model == ModelKind::kComplex) truth(3) = std::log10(kDefaultL);
    truth(truth.size() - 2) = 0.02 * 3.14159265358979 / 180.0;
    truth(truth.size() - 1) = 0.0;
    std::printf("log posterior at the start %.6f (%s), at the truth %.6f (%.6f at rtol 1e-10)\n", lp,
                problem.start_from_scan() ? "prior scan" : "point fit", problem.LogPosterior(truth),
                reference.LogPosterior(truth));
  }
  const PosteriorResult r = SamplePosterior(problem, o);
  std::printf("case %s, model %s, rtol %g, integrator %s, output stride %d%s: %d walkers x %d steps, %d threads\n",
              which.c_str(), r.model.c_str(), o.rtol, integrator.c_str(), o.output_stride,
              !forced && o.model == ModelKind::kHousner && o.free_rk4 ? " (free: SampleFreeHousner, RK4)" : "",
              r.walkers, r.steps, r.threads);
  std::printf("point fit and set-up %.2f s; sampler %.2f s wall (%.3f ms per log posterior)\n", setup, r.runtime_s,
              r.runtime_s * 1e3 * r.threads / (static_cast<double>(r.walkers) * r.steps));
  for (const ParameterSummary& s : r.summary) {
    std::printf("  %-9s median %.6g  68 %% [%.6g, %.6g]  sd %.3g  R-hat %.4f  ESS %.0f  tau %.1f\n", s.name.c_str(),
                s.median, s.ci68_lo, s.ci68_hi, s.sd, s.rhat, s.ess, s.tau);
  }
  std::printf("correlation alpha-p %.4f, alpha-mu %.4f, p-mu %.4f\n", r.correlation(0, 1), r.correlation(0, 2),
              r.correlation(1, 2));
  std::printf("acceptance %.3f; %s\n", r.diagnostics.acceptance, r.converged() ? "converged" : "NOT converged");
  for (const std::string& p : r.problems) std::printf("  %s\n", p.c_str());
  return 0;
}
