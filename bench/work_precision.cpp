// rocklab_bench_work_precision TRUTH.csv [OUT.svg]: the models' work
// against their precision, to choose each path's tolerance
// (docs/performance.md, "Work and precision").
//
// For rtol = 1e-6 .. 1e-12 (absolute tolerance rtol x 1e-2 rad, the scale
// of a peak), both models, two paths:
// - simulate: figure 8 (block 2 under 6 mm at 5 Hz for 20 s, smooth exact
//   forcing), Simulate (AdvanceAhead) with outputs at 200 Hz, the path of
//   `rocklab simulate` and `sweep`;
// - node: TRUTH.csv's table acceleration (a `rocklab synth --truth` file at
//   1 kHz) with 0.05 m/s^2 of Gaussian noise (seed 1, an accelerometer's),
//   fed sample by sample with Step, the path of the model node (`run`,
//   `model`).
// Each path also with ARKODE's explicit Runge-Kutta ("rk") beside CVODE's
// Adams.
// Error against the same path at rtol 1e-13: the relative error of the
// peak |theta| and the largest impact-time error (simulate), the largest
// |theta - reference| over every sample and the impact-time error (node).
// Work: CVODE steps, right-hand-side evaluations, CPU (std::clock, best of
// three). Prints a table; writes the diagram (error against CPU, log-log).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "model/rocking_model.h"

namespace {

using namespace rocklab::model;

struct Run {
  std::vector<double> theta;    // rad, every output
  std::vector<double> impacts;  // s
  long steps{}, rhs{};
  double cpu_s{};
};

struct Point {
  std::string path, model;
  double rtol{}, error{}, time_error_s{}, cpu_s{};
  long steps{}, rhs{};
  bool same_impacts{};
};

ModelOptions Options(double rtol, Integrator integrator = Integrator::kAdams) {
  ModelOptions o;
  o.rtol = rtol;
  o.atol = rtol * 1e-2;
  o.integrator = integrator;
  return o;
}

std::vector<double> Impacts(const std::vector<ModelEvent>& events) {
  std::vector<double> out;
  for (const auto& e : events) {
    if (e.kind == EventKind::kImpact) out.push_back(e.time_s);
  }
  return out;
}

template <typename F>
Run Best(F once) {
  Run best;
  best.cpu_s = 1e300;
  for (int rep = 0; rep < 3; ++rep) {
    const std::clock_t c0 = std::clock();
    Run r = once();
    r.cpu_s = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
    if (r.cpu_s < best.cpu_s) best = r;
  }
  return best;
}

Run Simulated(ModelKind kind, double rtol, Integrator integrator = Integrator::kAdams) {
  const BlockParams block{0.168, 3.767, 0.942};
  const auto sine = MakeSine({0.006, 5.0, 20.0, 0.0});
  return Best([&] {
    auto m = RockingModel::Create(kind, block, Options(rtol, integrator));
    const Trajectory t = Simulate(*m, *sine, 0.0, 0.0, 0.0, 20.0, 200.0);
    Run r;
    r.theta = t.theta;
    r.impacts = Impacts(t.events);
    r.steps = m->solver_stats().steps;
    r.rhs = m->solver_stats().rhs_evals;
    return r;
  });
}

Run Stepped(ModelKind kind, double rtol, const std::vector<double>& time, const std::vector<double>& accel,
            Integrator integrator = Integrator::kAdams) {
  const BlockParams block{0.235, 3.884, 0.937};
  return Best([&] {
    auto m = RockingModel::Create(kind, block, Options(rtol, integrator));
    m->Reset(time.front(), 0.0, 0.0);
    Run r;
    r.theta.reserve(time.size());
    for (std::size_t k = 0; k < time.size(); ++k) {
      m->Step(time[k], accel[k]);
      r.theta.push_back(m->state().theta);
    }
    r.impacts = Impacts(m->events());
    r.steps = m->solver_stats().steps;
    r.rhs = m->solver_stats().rhs_evals;
    return r;
  });
}

double PeakAbs(const std::vector<double>& v) {
  double m = 0;
  for (double x : v) m = std::max(m, std::abs(x));
  return m;
}

Point Compare(const char* path, ModelKind kind, double rtol, const Run& got, const Run& ref, bool peak_relative) {
  Point p;
  p.path = path;
  p.model = ToString(kind);
  p.rtol = rtol;
  p.cpu_s = got.cpu_s;
  p.steps = got.steps;
  p.rhs = got.rhs;
  p.same_impacts = got.impacts.size() == ref.impacts.size();
  for (std::size_t i = 0; i < std::min(got.impacts.size(), ref.impacts.size()); ++i) {
    p.time_error_s = std::max(p.time_error_s, std::abs(got.impacts[i] - ref.impacts[i]));
  }
  if (peak_relative) {
    p.error = std::abs(PeakAbs(got.theta) / PeakAbs(ref.theta) - 1);
  } else {
    for (std::size_t i = 0; i < got.theta.size(); ++i) p.error = std::max(p.error, std::abs(got.theta[i] - ref.theta[i]));
  }
  return p;
}

// The diagram: error against CPU, log-log, one line per path and model.
void WriteSvg(const std::string& file, const std::vector<Point>& points) {
  const double w = 720, h = 480, left = 80, right = 180, top = 30, bottom = 60;
  double xmin = 1e300, xmax = 0, ymin = 1e300, ymax = 0;
  for (const Point& p : points) {
    const double e = std::max(p.error, 1e-16);
    xmin = std::min(xmin, p.cpu_s);
    xmax = std::max(xmax, p.cpu_s);
    ymin = std::min(ymin, e);
    ymax = std::max(ymax, e);
  }
  const double lx0 = std::floor(std::log10(xmin)), lx1 = std::ceil(std::log10(xmax));
  const double ly0 = std::floor(std::log10(ymin)), ly1 = std::ceil(std::log10(ymax));
  auto X = [&](double v) { return left + (std::log10(v) - lx0) / (lx1 - lx0) * (w - left - right); };
  auto Y = [&](double v) {
    return top + (ly1 - std::log10(std::max(v, 1e-16))) / (ly1 - ly0) * (h - top - bottom);
  };
  std::ostringstream s;
  s << "<svg xmlns='http://www.w3.org/2000/svg' width='" << w << "' height='" << h
    << "' font-family='sans-serif' font-size='12'>\n<rect width='100%' height='100%' fill='white'/>\n";
  for (double e = lx0; e <= lx1; ++e) {
    s << "<line x1='" << X(std::pow(10, e)) << "' y1='" << top << "' x2='" << X(std::pow(10, e)) << "' y2='"
      << h - bottom << "' stroke='#ddd'/><text x='" << X(std::pow(10, e)) << "' y='" << h - bottom + 16
      << "' text-anchor='middle'>1e" << e << "</text>\n";
  }
  for (double e = ly0; e <= ly1; ++e) {
    s << "<line x1='" << left << "' y1='" << Y(std::pow(10, e)) << "' x2='" << w - right << "' y2='"
      << Y(std::pow(10, e)) << "' stroke='#ddd'/><text x='" << left - 6 << "' y='" << Y(std::pow(10, e)) + 4
      << "' text-anchor='end'>1e" << e << "</text>\n";
  }
  s << "<text x='" << (left + w - right) / 2 << "' y='" << h - 20 << "' text-anchor='middle'>CPU, s</text>\n"
    << "<text x='16' y='" << (top + h - bottom) / 2 << "' transform='rotate(-90 16 " << (top + h - bottom) / 2
    << ")' text-anchor='middle'>error (simulate: peak, relative; node: theta, rad)</text>\n";
  const char* colours[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#17becf", "#7f7f7f"};
  int line = 0;
  for (const char* path : {"simulate", "simulate rk", "node", "node rk"}) {
    for (const char* model : {"housner", "complex"}) {
      std::string pts;
      for (const Point& p : points) {
        if (p.path != path || p.model != model) continue;
        pts += std::to_string(X(p.cpu_s)) + "," + std::to_string(Y(p.error)) + " ";
        s << "<text x='" << X(p.cpu_s) + 4 << "' y='" << Y(p.error) - 4 << "' font-size='9' fill='"
          << colours[line] << "'>" << p.rtol << "</text>\n";
      }
      s << "<polyline fill='none' stroke='" << colours[line] << "' stroke-width='2' points='" << pts << "'/>\n"
        << "<text x='" << w - right + 10 << "' y='" << top + 20 + 18 * line << "' fill='" << colours[line] << "'>"
        << path << ", " << model << "</text>\n";
      ++line;
    }
  }
  s << "</svg>\n";
  const std::string tmp = file + ".tmp";
  std::ofstream(tmp) << s.str();
  std::rename(tmp.c_str(), file.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: rocklab_bench_work_precision TRUTH.csv [OUT.svg]\n");
    return 2;
  }
  std::vector<double> time, accel;
  {
    std::ifstream in(argv[1]);
    std::string line;
    std::getline(in, line);  // time,theta,theta_dot,table_displacement,table_acceleration,...
    std::mt19937 rng(1);
    std::normal_distribution<double> noise(0.0, 0.05);
    while (std::getline(in, line) && time.size() < 60000) {
      std::istringstream fields(line);
      std::string f[5];
      for (auto& x : f) std::getline(fields, x, ',');
      time.push_back(std::stod(f[0]));
      accel.push_back(std::stod(f[4]) + noise(rng));
    }
  }
  if (time.size() < 2) {
    std::fprintf(stderr, "%s: no samples\n", argv[1]);
    return 2;
  }
  const double rtols[] = {1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12};
  std::vector<Point> points;
  std::printf("| path | model | rtol | error | impact time error (s) | same impacts | steps | rhs | CPU (s) |\n"
              "|---|---|---|---|---|---|---|---|---|\n");
  for (ModelKind kind : {ModelKind::kHousner, ModelKind::kComplex}) {
    const Run sim_ref = Simulated(kind, 1e-13);
    const Run node_ref = Stepped(kind, 1e-13, time, accel);
    for (double rtol : rtols) {
      points.push_back(Compare("simulate", kind, rtol, Simulated(kind, rtol), sim_ref, true));
      points.push_back(
          Compare("simulate rk", kind, rtol, Simulated(kind, rtol, Integrator::kRungeKutta), sim_ref, true));
      points.push_back(Compare("node", kind, rtol, Stepped(kind, rtol, time, accel), node_ref, false));
      points.push_back(Compare("node rk", kind, rtol, Stepped(kind, rtol, time, accel, Integrator::kRungeKutta),
                               node_ref, false));
    }
  }
  std::sort(points.begin(), points.end(), [](const Point& a, const Point& b) {
    return a.path != b.path ? a.path < b.path : a.model != b.model ? a.model > b.model : a.rtol > b.rtol;
  });
  for (const Point& p : points) {
    std::printf("| %s | %s | %.0e | %.2e %s | %.2e | %s | %ld | %ld | %.4f |\n", p.path.c_str(), p.model.c_str(),
                p.rtol, p.error, p.path.rfind("simulate", 0) == 0 ? "(peak, rel.)" : "rad", p.time_error_s,
                p.same_impacts ? "yes" : "NO", p.steps, p.rhs, p.cpu_s);
  }
  if (argc > 2) WriteSvg(argv[2], points);
  return 0;
}
