// Coverage of the fits' stated standard errors (docs/fit_coverage.md):
// synthetic records with known (alpha, p, mu), drawn per record from a box,
// theta from the tests' RK4 reference of Housner's equation
// (tests/model/fit_synthetic.h, not the model code the fits use), seeded
// Gaussian noise; each record fitted, and the fraction of records whose
// truth lies within 1 and 1.96 stated standard errors counted per
// parameter (nominal 68.3 % and 95 %).
//
//   rocklab_bench_fit_coverage --method impacts|free|forced|threshold [--records N]
//       [--seed S] [--noise-deg D] [--starts N] [--table chord|spline] [--csv FILE]
//
// One line per record on --csv (method, seed, truth, fit, stated errors,
// converged, p-value), the summary on stdout.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "model/excitation.h"
#include "model/fit.h"
#include "tests/model/fit_synthetic.h"

namespace {

using rocklab::model::BlockParams;

struct Args {
  std::string method{"impacts"};
  int records{200};
  unsigned seed{1000};
  double noise_deg{0.02};
  std::string csv;
  int starts{-1};  // FitOptions::starts (-1: the method's default)
  bool spline{true};  // forced: FitOptions::table_interpolation (the spline by default, as `rocklab fit`)
};

struct Case {
  BlockParams truth;
  rocklab::model::RockingRecord record;
  std::optional<rocklab::model::FitGeometry> geometry;
};

// The record of seed s: truth drawn from the box of the method.
Case MakeCase(const Args& a, unsigned s) {
  std::mt19937 rng(s);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Case c;
  if (a.method == "forced") {
    // Slender blocks of 1 m height under a Hanning sine of 8-12 mm at
    // 3.3 Hz (figure 7's motion, larger so that every record rocks); the
    // record shared with the tests (fit_synthetic.h).
    rocklab::test::CoverageForcedCase f = rocklab::test::MakeCoverageForcedCase(s, a.noise_deg);
    c.truth = f.truth;
    c.geometry = f.geometry;
    c.record = std::move(f.record);
  } else if (a.method == "threshold") {
    // The figure-7-like forced test near the uplift threshold, the
    // truth fixed and the noise drawn per seed (the test
    // FitTrajectory.ForcedNearThresholdFindsTheTruthOrSaysNotConverged is
    // seed 8): block 0.225 x 1.0 m, Hanning 6 mm at 3.3 Hz for 4 s from
    // 0.5 s, 7 s of theta at 500 Hz, table at 1 kHz.
    c.truth = {std::atan(0.1125 / 0.5), 3.85, 0.93};
    c.geometry = rocklab::model::FitGeometry{0.225, 1.0, 0.0};
    const auto ex = rocklab::model::ParseExcitation("hanning:amp=0.006,freq=3.3,duration=4,start=0.5");
    c.record = rocklab::test::SyntheticForced(c.truth, *ex, 7.0, 500, 1000, a.noise_deg, s);
  } else {
    c.truth = {0.20 + 0.10 * u(rng), 3.0 + 1.5 * u(rng), 0.88 + 0.08 * u(rng)};
    const double theta0 = (0.4 + 0.4 * u(rng)) * c.truth.alpha;
    c.record = rocklab::test::SyntheticFree(c.truth, theta0, 0.3, 8.0, 500, a.noise_deg, s);
  }
  return c;
}

struct Tally {
  int in68[3]{}, in95[3]{};
  double z2[3]{};
  int n{};
  void Add(const double z[3]) {
    for (int i = 0; i < 3; ++i) {
      in68[i] += std::abs(z[i]) <= 1.0;
      in95[i] += std::abs(z[i]) <= 1.959964;
      z2[i] += z[i] * z[i];
    }
    ++n;
  }
  void Print(const char* what) const {
    const char* names[3] = {"alpha", "p", "mu"};
    std::printf("%s: %d records\n", what, n);
    if (n == 0) return;
    for (int i = 0; i < 3; ++i) {
      std::printf("  %-5s  68 %%: %5.1f %%   95 %%: %5.1f %%   rms(error / stated) %.3f\n", names[i],
                  100.0 * in68[i] / n, 100.0 * in95[i] / n, std::sqrt(z2[i] / n));
    }
  }
};

int Main(const Args& a) {
  std::ofstream csv;
  if (!a.csv.empty()) {
    csv.open(a.csv);
    csv << "method,seed,alpha_true,p_true,mu_true,alpha,p,mu,alpha_stderr,p_stderr,mu_stderr,converged,"
           "p_value,chi2_per_dof,runtime_s,band_p_value,band_ratio,error\n";
  }
  Tally converged, all;
  int failed = 0, not_converged = 0;
  double runtime = 0.0;
  const auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < a.records; ++i) {
    const unsigned s = a.seed + static_cast<unsigned>(i);
    const Case c = MakeCase(a, s);
    rocklab::model::FitOptions o;
    o.geometry = c.geometry;
    o.starts = a.starts;
    o.table_interpolation = a.spline ? rocklab::model::Interpolation::kSpline : rocklab::model::Interpolation::kLinear;
    try {
      const auto r = a.method == "impacts" ? rocklab::model::FitImpacts(c.record, o)
                                           : rocklab::model::FitTrajectory(c.record, o);
      const double z[3] = {(r.params.alpha - c.truth.alpha) / r.alpha_stderr, (r.params.p - c.truth.p) / r.p_stderr,
                           (r.params.mu - c.truth.mu) / r.mu_stderr};
      all.Add(z);
      if (r.converged) {
        converged.Add(z);
      } else {
        ++not_converged;
      }
      runtime += r.runtime_s;
      if (csv) {
        csv.precision(10);
        csv << a.method << ',' << s << ',' << c.truth.alpha << ',' << c.truth.p << ',' << c.truth.mu << ','
            << r.params.alpha << ',' << r.params.p << ',' << r.params.mu << ',' << r.alpha_stderr << ','
            << r.p_stderr << ',' << r.mu_stderr << ',' << r.converged << ',' << r.p_value << ','
            << r.chi2_per_dof << ',' << r.runtime_s << ',' << r.band_p_value << ',' << r.band_ratio << ",\n";
        csv.flush();  // a long run read while it goes (bench/fit_coverage_table.py)
      }
    } catch (const std::exception& e) {
      ++failed;
      if (csv) csv << a.method << ',' << s << ",,,,,,,,,,0,,,,,,\"" << e.what() << "\"\n";
    }
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::printf("method %s, %d records from seed %u, noise %.3g deg: %d not converged, %d refused; "
              "fits %.1f s, wall %.1f s\n",
              a.method.c_str(), a.records, a.seed, a.noise_deg, not_converged, failed, runtime, wall);
  converged.Print("converged");
  all.Print("all fitted");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Args a;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--method") {
      a.method = v;
    } else if (k == "--records") {
      a.records = std::atoi(v.c_str());
    } else if (k == "--seed") {
      a.seed = static_cast<unsigned>(std::atol(v.c_str()));
    } else if (k == "--noise-deg") {
      a.noise_deg = std::atof(v.c_str());
    } else if (k == "--starts") {
      a.starts = std::atoi(v.c_str());
    } else if (k == "--table" && (v == "chord" || v == "spline")) {
      a.spline = v == "spline";
    } else if (k == "--csv") {
      a.csv = v;
    } else {
      std::fprintf(stderr, "unknown option %s\n", k.c_str());
      return 2;
    }
  }
  if ((argc - 1) % 2 != 0 || !(a.method == "impacts" || a.method == "free" || a.method == "forced" || a.method == "threshold") ||
      a.records < 1) {
    std::fprintf(stderr, "usage: %s --method impacts|free|forced|threshold [--records N] [--seed S] [--noise-deg D] "
                 "[--starts N] [--table chord|spline] [--csv FILE]\n", argv[0]);
    return 2;
  }
  return Main(a);
}
