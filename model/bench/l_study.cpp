// Which l the complex formulation needs (docs/models.md, "Choosing l"): for
// each l, against eq. (10)'s l -> 0 limit integrated by the tests' RK4
// reference (tests/model/rk4_reference.h, RefOptions::limit_w: not the
// model code), the overturning threshold of a half-sine pulse
// a_p sin(pi t / tp) on [0, tp] (bisection to 1e-6 g), the first 10
// free-rocking impact times of the block from alpha / 2 (largest |dt|), and
// the cost (CPU s of the 10 s threshold run at the threshold, CVODE steps).
//
//   rocklab_l_study [--l 1e-8,1e-10,...] [--alpha A --p P --mu M --tp S]
//
// Figures are printed, never asserted (the tests assert the default).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <sstream>
#include <string>
#include <vector>

#include "model/rocking_model.h"
#include "tests/model/rk4_reference.h"

namespace {

using rocklab::model::BlockParams;
using rocklab::model::EventKind;
using rocklab::model::ModelKind;
using rocklab::model::ModelOptions;
using rocklab::model::RockingModel;
namespace rk4 = rocklab::test::rk4;

constexpr double kPi = 3.14159265358979323846;

class HalfSine final : public rocklab::model::Forcing {
 public:
  HalfSine(double a, double tp) : a_(a), tp_(tp) {}
  double TableAcceleration(double t) const override { return t >= 0 && t <= tp_ ? a_ * std::sin(kPi * t / tp_) : 0.0; }
  double NextDiscontinuity(double t) const override {
    return t < tp_ ? tp_ : std::numeric_limits<double>::infinity();
  }

 private:
  double a_, tp_;
};

double Cpu() { return static_cast<double>(std::clock()) / CLOCKS_PER_SEC; }

struct Args {
  std::vector<double> ls{1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13, 1e-14, 1e-15, 1e-16};
  BlockParams block{0.235, 3.884, 0.937};
  double tp{0.5};
  double duration{10.0};
};

bool ModelOverturns(const Args& a, double l, double a_g, double* cpu = nullptr, long* steps = nullptr) {
  ModelOptions o;
  o.l = l;
  auto m = RockingModel::Create(ModelKind::kComplex, a.block, o);
  const HalfSine f(a_g * rk4::kG, a.tp);
  const double c0 = Cpu();
  m->Reset(0.0, 0.0, 0.0);
  m->AdvanceTo(a.duration, f);
  if (cpu) *cpu = Cpu() - c0;
  if (steps) *steps = m->solver_stats().steps;
  for (const auto& e : m->events()) {
    if (e.kind == EventKind::kOverturn) return true;
  }
  return false;
}

bool LimitOverturns(const Args& a, double a_g) {
  rk4::RefOptions o;
  o.limit_w = std::sqrt(1 - std::pow(std::log(a.block.mu) / kPi, 2));
  o.breaks_s = {a.tp};
  o.sample_rate_hz = 100;
  const double amp = a_g * rk4::kG, tp = a.tp;
  const auto accel = [amp, tp](double t, bool left) {
    const bool in = left ? (t > 0 && t <= tp) : (t >= 0 && t < tp);
    return in ? amp * std::sin(kPi * t / tp) : 0.0;
  };
  const rk4::RefResult r = rk4::Reference(a.block, accel, o).Run(a.duration);
  return r.sample_theta.size() < static_cast<std::size_t>(std::lround(a.duration * 100)) + 1;
}

template <typename F>
double Bisect(F overturns, double lo, double hi) {
  while (hi - lo > 1e-6) {
    const double mid = 0.5 * (lo + hi);
    (overturns(mid) ? hi : lo) = mid;
  }
  return 0.5 * (lo + hi);
}

// A bracket [lo, hi] of the limit's threshold: scan up from g tan(alpha).
std::pair<double, double> Bracket(const Args& a) {
  double lo = std::tan(a.block.alpha);
  for (double x = lo; x < 20; x *= 1.05) {
    if (LimitOverturns(a, x)) return {lo, x};
    lo = x;
  }
  return {lo, lo};
}

std::vector<double> FreeImpacts(const BlockParams& b, double l, bool limit) {
  const double theta0 = b.alpha / 2;
  std::vector<double> times;
  if (limit) {
    rk4::RefOptions o;
    o.limit_w = std::sqrt(1 - std::pow(std::log(b.mu) / kPi, 2));
    o.theta0 = theta0;
    o.sample_rate_hz = 100;
    const rk4::RefResult r = rk4::Reference(b, [](double, bool) { return 0.0; }, o).Run(5.0);
    times = r.impact_times;
  } else {
    ModelOptions o;
    o.l = l;
    auto m = RockingModel::Create(ModelKind::kComplex, b, o);
    const rocklab::model::NoTableMotion none;
    m->Reset(0.0, theta0, 0.0);
    m->AdvanceTo(5.0, none);
    for (const auto& e : m->events()) {
      if (e.kind == EventKind::kImpact) times.push_back(e.time_s);
    }
  }
  if (times.size() > 10) times.resize(10);
  return times;
}

}  // namespace

int main(int argc, char** argv) {
  Args a;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--l") {
      a.ls.clear();
      std::stringstream s(v);
      std::string x;
      while (std::getline(s, x, ',')) a.ls.push_back(std::atof(x.c_str()));
    } else if (k == "--alpha") {
      a.block.alpha = std::atof(v.c_str());
    } else if (k == "--p") {
      a.block.p = std::atof(v.c_str());
    } else if (k == "--mu") {
      a.block.mu = std::atof(v.c_str());
    } else if (k == "--tp") {
      a.tp = std::atof(v.c_str());
    } else {
      std::fprintf(stderr, "usage: %s [--l L1,L2,..] [--alpha A] [--p P] [--mu M] [--tp S]\n", argv[0]);
      return 2;
    }
  }
  const auto [lo, hi] = Bracket(a);
  const double limit = Bisect([&](double x) { return LimitOverturns(a, x); }, lo, hi);
  const std::vector<double> limit_impacts = FreeImpacts(a.block, 0, true);
  std::printf("block alpha %.4f rad, p %.4f rad/s, mu %.4f; half-sine tp %.3f s\n", a.block.alpha, a.block.p,
              a.block.mu, a.tp);
  std::printf("l -> 0 limit (RK4 reference): threshold %.6f g; 10th free impact %.7f s\n", limit,
              limit_impacts.back());
  std::printf("| l | threshold (g) | - limit (g) | rel. | dt10 (s) | CPU s (threshold run) | steps |\n");
  std::printf("|---|---|---|---|---|---|---|\n");
  for (double l : a.ls) {
    const double th = Bisect([&](double x) { return ModelOverturns(a, l, x); }, 0.8 * limit, 1.2 * limit);
    double cpu = 0;
    long steps = 0;
    ModelOverturns(a, l, th, &cpu, &steps);
    const std::vector<double> imp = FreeImpacts(a.block, l, false);
    double dt = 0;
    for (std::size_t k = 0; k < imp.size() && k < limit_impacts.size(); ++k) {
      dt = std::max(dt, std::abs(imp[k] - limit_impacts[k]));
    }
    if (imp.size() != limit_impacts.size()) dt = std::nan("");
    std::printf("| %.0e | %.6f | %+.2e | %+.1e | %.1e | %.3f | %ld |\n", l, th, th - limit, th / limit - 1, dt, cpu,
                steps);
    std::fflush(stdout);
  }
  return 0;
}
