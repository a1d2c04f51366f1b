#pragma once
// Synthetic records for the fit tests: Housner's equation integrated by the
// tests' own RK4 reference (rk4_reference.h: not the model code the fits
// use), sampled like a test, with seeded Gaussian noise.

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "model/excitation.h"
#include "model/fit.h"
#include "model/test_record.h"
#include "model/rocking_model.h"
#include "tests/model/rk4_reference.h"

namespace rocklab::test {

inline constexpr double kDeg = 3.14159265358979323846 / 180.0;

/// Free rocking: the block is held at theta0 for hold_s, then released; the
/// record runs to hold_s + duration_s at rate_hz with N(0, noise_deg) noise.
/// theta from the tests' RK4 reference (rk4_reference.h, h = 1e-5 s: ~1e-12
/// rad), not rocklab's Housner model, which the fits use themselves.
/// hold_s * rate_hz must be whole (the release on a sample). A block that
/// overturns stays at +-pi/2 (as rocklab's model stops there). Impact n
/// keeps mu_per_impact[n] of the speed where given (else truth.mu).
inline model::RockingRecord SyntheticFree(const model::BlockParams& truth, double theta0,
                                          double hold_s, double duration_s, double rate_hz,
                                          double noise_deg, std::uint32_t seed,
                                          const std::string& name = "synthetic-free",
                                          const std::vector<double>& mu_per_impact = {}) {
  const long hold_n = std::lround(hold_s * rate_hz);
  if (std::abs(static_cast<double>(hold_n) - hold_s * rate_hz) > 1e-9) {
    throw std::logic_error("SyntheticFree: hold_s * rate_hz must be whole");
  }
  rk4::RefOptions o;
  o.theta0 = theta0;
  o.sample_rate_hz = rate_hz;
  o.mu_per_impact = mu_per_impact;
  const rk4::RefResult ref = rk4::Reference(truth, [](double, bool) { return 0.0; }, o).Run(duration_s);
  if (ref.sample_theta.empty()) throw std::logic_error("SyntheticFree: no sample");
  const double fallen = std::copysign(rk4::kPi / 2, theta0);
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_deg * kDeg);
  model::RockingRecord r;
  r.source = name;
  const auto n = static_cast<long>(std::floor((hold_s + duration_s) * rate_hz));
  for (long k = 0; k <= n; ++k) {
    const double t = static_cast<double>(k) / rate_hz;
    double theta = theta0;
    if (k >= hold_n) {
      const auto j = static_cast<std::size_t>(k - hold_n);
      theta = j < ref.sample_theta.size() ? ref.sample_theta[j] : fallen;
    }
    r.time_s.push_back(t);
    r.theta.push_back(theta + noise(rng));
    r.line.push_back(k + 2);
  }
  return r;
}

/// Forced rocking from rest: the RK4 reference driven by `excitation` (its
/// acceleration, exact; steps land on its discontinuities and take each
/// side's value there), the record holding theta at rate_hz with noise and
/// the table acceleration sampled at table_rate_hz (exact values, as an
/// accelerometer without noise).
inline model::RockingRecord SyntheticForced(const model::BlockParams& truth,
                                            const model::Excitation& excitation,
                                            double duration_s, double rate_hz,
                                            double table_rate_hz, double noise_deg,
                                            std::uint32_t seed) {
  rk4::RefOptions o;
  o.sample_rate_hz = rate_hz;
  for (double b = excitation.NextDiscontinuity(0.0); b <= duration_s; b = excitation.NextDiscontinuity(b)) {
    o.breaks_s.push_back(b);
  }
  const auto accel = [&excitation](double t, bool left) {
    const double side = left ? -std::numeric_limits<double>::infinity() : std::numeric_limits<double>::infinity();
    return excitation.TableAcceleration(std::nextafter(t, side));
  };
  const rk4::RefResult ref = rk4::Reference(truth, accel, o).Run(duration_s);
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_deg * kDeg);
  model::RockingRecord r;
  r.source = "synthetic-forced";
  const auto n = static_cast<long>(std::floor(duration_s * rate_hz));
  if (ref.sample_theta.size() < static_cast<std::size_t>(n + 1)) {
    throw std::logic_error("SyntheticForced: the block overturned");
  }
  for (long k = 0; k <= n; ++k) {
    r.time_s.push_back(static_cast<double>(k) / rate_hz);
    r.theta.push_back(ref.sample_theta[static_cast<std::size_t>(k)] + noise(rng));
    r.line.push_back(k + 2);
  }
  const auto nt = static_cast<long>(std::floor(duration_s * table_rate_hz));
  for (long k = 0; k <= nt; ++k) {
    const double t = static_cast<double>(k) / table_rate_hz;
    r.table_time_s.push_back(t);
    r.table_accel_mps2.push_back(excitation.TableAcceleration(t));
  }
  return r;
}

/// The forced record of the coverage bench's seed (bench/fit_coverage.cpp,
/// docs/fit_coverage.md): alpha in [0.20, 0.26], mu in [0.90, 0.96], a 1 m
/// high block whose geometry has b within +-2 mm of the truth's and p
/// 0.95-1.05 of the geometry's; a Hanning sine of 8-12 mm at 3.3 Hz (4 s
/// from 0.5 s); 6 s of theta at 250 Hz with the given noise, the table
/// acceleration at 1 kHz, exact. The bench and the tests share it, so that a
/// test reproduces a bench record exactly.
struct CoverageForcedCase {
  model::BlockParams truth;
  model::FitGeometry geometry;
  model::RockingRecord record;
};
inline CoverageForcedCase MakeCoverageForcedCase(std::uint32_t seed, double noise_deg) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  CoverageForcedCase c;
  c.truth = {0.20 + 0.06 * u(rng), 0.0, 0.90 + 0.06 * u(rng)};
  const double height = 1.0;
  const double db = 0.004 * (u(rng) - 0.5);
  c.geometry = model::FitGeometry{height * std::tan(c.truth.alpha) + 2 * db, height, 0.0};
  const double r = 0.5 * std::hypot(c.geometry.width_m, height);
  c.truth.p = std::sqrt(3.0 * 9.81 / (4.0 * r)) * (0.95 + 0.10 * u(rng));
  const double amp = 0.008 + 0.004 * u(rng);
  const auto ex = model::ParseExcitation("hanning:amp=" + std::to_string(amp) + ",freq=3.3,duration=4,start=0.5");
  c.record = SyntheticForced(c.truth, *ex, 6.0, 250, 1000, noise_deg, seed);
  return c;
}

/// Removes each sample with probability `fraction` (seeded) and then the
/// `block` samples from index `block_at` on (none when block is 0), as a DAQ
/// that drops samples; returns how many were removed. The lines of the
/// samples kept are unchanged.
inline long DropSamples(model::RockingRecord& r, double fraction, std::uint32_t seed, long block_at = 0,
                        long block = 0) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  model::RockingRecord out = r;
  out.time_s.clear();
  out.theta.clear();
  out.line.clear();
  long removed = 0;
  for (std::size_t k = 0; k < r.size(); ++k) {
    const long i = static_cast<long>(k);
    const bool in_block = block > 0 && i >= block_at && i < block_at + block;
    // Never the first or the last sample: a gap is between samples.
    if (k > 0 && k + 1 < r.size() && (in_block || u(rng) < fraction)) {
      ++removed;
      continue;
    }
    out.time_s.push_back(r.time_s[k]);
    out.theta.push_back(r.theta[k]);
    out.line.push_back(r.line[k]);
  }
  out.theta_gaps = model::CountGaps(out.time_s, out.line);
  r = std::move(out);
  return removed;
}

}  // namespace rocklab::test
