// rocklab_bench_node_sample TRUTH.csv: the model node's cost per table
// sample beside the physical floor (docs/performance.md, "Per-sample cost
// of the model node").
//
// TRUTH.csv is a `rocklab synth --truth` file at 1 kHz (the bench's run
// record); its table acceleration with 0.05 m/s^2 of Gaussian noise (seed
// 1, an accelerometer's), as the pipeline carries it. Printed, in ns per
// sample (CPU, std::clock, best of three over the whole record):
// - floor: one classical RK4 step of Housner's equation per sample, the
//   acceleration linear between samples, no error control, no events: the
//   least any integrator that looks at every sample does;
// - each model alone, stepped with RockingModel::Step as the node does
//   (ModelNodeConfig's integrator, rtol 1e-10), with its steps and
//   right-hand sides per sample; then with ARKODE's Runge-Kutta 5;
// - the model node with the four variants of bench/figures.py on a
//   DirectBus: RL_THETA and RL_TABLE in, the four RL_MODEL_* out (encoded
//   and published, nobody subscribed), one thread.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "common/direct_bus.h"
#include "model/model_node.h"
#include "model/numbers.h"
#include "model/rocking_model.h"
#include "model/variant.h"

namespace {

using namespace rocklab::model;

const BlockParams kFitted{0.235, 3.884, 0.937};
const BlockParams kTheoretical{0.2422, 3.7796, 0.914};

template <typename F>
double BestNsPerSample(std::size_t samples, F once) {
  double best = 1e300;
  for (int rep = 0; rep < 3; ++rep) {
    const std::clock_t c0 = std::clock();
    once();
    best = std::min(best, static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC);
  }
  return best / static_cast<double>(samples) * 1e9;
}

// Housner's equation on the +x pivot (theta > 0 side; the sign flips are
// not what costs), table acceleration linear between samples.
double FloorRk4(const std::vector<double>& accel, double dt) {
  const BlockParams& b = kFitted;
  const double p2 = b.p * b.p;
  auto f = [&](double theta, double ug, double& dtheta, double& ddtheta, double omega) {
    const double phi = b.alpha - theta;
    dtheta = omega;
    ddtheta = -p2 * (std::sin(phi) + ug / kGravity * std::cos(phi));
  };
  double theta = 1e-3, omega = 0.0;
  for (std::size_t k = 1; k < accel.size(); ++k) {
    const double a0 = accel[k - 1], a1 = accel[k], am = 0.5 * (a0 + a1);
    double k1t, k1w, k2t, k2w, k3t, k3w, k4t, k4w;
    f(theta, a0, k1t, k1w, omega);
    f(theta + 0.5 * dt * k1t, am, k2t, k2w, omega + 0.5 * dt * k1w);
    f(theta + 0.5 * dt * k2t, am, k3t, k3w, omega + 0.5 * dt * k2w);
    f(theta + dt * k3t, a1, k4t, k4w, omega + dt * k3w);
    theta += dt / 6 * (k1t + 2 * k2t + 2 * k3t + k4t);
    omega += dt / 6 * (k1w + 2 * k2w + 2 * k3w + k4w);
  }
  return theta;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: rocklab_bench_node_sample TRUTH.csv\n");
    return 2;
  }
  std::vector<double> accel;
  {
    std::ifstream in(argv[1]);
    std::string line;
    std::getline(in, line);  // time,theta,theta_dot,table_displacement,table_acceleration,...
    std::mt19937 rng(1);
    std::normal_distribution<double> noise(0.0, 0.05);
    while (std::getline(in, line)) {
      std::istringstream fields(line);
      std::string f[5];
      for (auto& x : f) std::getline(fields, x, ',');
      accel.push_back(std::stod(f[4]) + noise(rng));
    }
  }
  if (accel.size() < 2) {
    std::fprintf(stderr, "%s: no samples\n", argv[1]);
    return 2;
  }
  const std::size_t n = accel.size();
  const double dt = 1e-3;
  std::printf("%zu samples at 1 kHz (%s)\n", n, argv[1]);
  volatile double sink = 0;
  std::printf("floor: one RK4 step per sample (Housner)       %7.1f ns/sample\n",
              BestNsPerSample(n, [&] { sink = FloorRk4(accel, dt); }));

  // The node's integrator (ModelNodeConfig's default), and ARKODE's
  // Runge-Kutta 5 (the default before issue 33) beside it.
  for (Integrator integrator : {ModelNodeConfig{}.integrator, Integrator::kRungeKutta}) {
    ModelOptions node_options;
    node_options.integrator = integrator;
    for (ModelKind kind : {ModelKind::kHousner, ModelKind::kComplex}) {
      SolverStats stats;
      const double ns = BestNsPerSample(n, [&] {
        auto m = RockingModel::Create(kind, kFitted, node_options);
        m->Reset(0.0, 0.0, 0.0);
        for (std::size_t k = 0; k < n; ++k) m->Step(static_cast<double>(k) * dt, accel[k]);
        stats = m->solver_stats();
      });
      std::printf("model alone, %-8s Step (%s)                %7.1f ns/sample  %.3f steps, %.2f rhs per sample\n",
                  ToString(kind), ToString(node_options.integrator), ns,
                  static_cast<double>(stats.steps) / static_cast<double>(n),
                  static_cast<double>(stats.rhs_evals) / static_cast<double>(n));
    }
    if (integrator == Integrator::kRungeKutta) break;
  }

  ModelNodeConfig config;
  for (const char* spec : {"fitted_complex:complex:alpha=0.235,p=3.884,mu=0.937",
                           "fitted_housner:housner:alpha=0.235,p=3.884,mu=0.937", "theory_complex:complex:theoretical",
                           "theory_housner:housner:theoretical"}) {
    config.variants.push_back(ParseVariant(spec, kTheoretical));
  }
  config.threads = 1;
  const double node_ns = BestNsPerSample(n, [&] {
    rocklab::common::DirectBus bus;
    ModelNode node(config, bus);
    rocklab::block_state_t theta{};
    rocklab::table_state_t table{};
    for (std::size_t k = 0; k < n; ++k) {
      const auto utime = static_cast<std::int64_t>(k) * 1000;
      theta.utime = table.utime = utime;
      theta.seq = table.seq = static_cast<std::int64_t>(k);
      table.acceleration = accel[k];
      bus.Publish("RL_THETA", theta);
      bus.Publish("RL_TABLE", table);
    }
    node.Finish();
  });
  std::printf("model node, 4 variants, 1 thread, DirectBus    %7.1f ns/sample  (%.1f ns per variant)\n", node_ns,
              node_ns / 4);
  return sink == 12345.0 ? 1 : 0;
}
