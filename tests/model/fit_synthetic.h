#pragma once
// Synthetic records for the fit tests: the Housner model (the oracle) sampled
// like a test, with seeded Gaussian noise.

#include <cmath>
#include <cstdint>
#include <random>
#include <string>

#include "model/excitation.h"
#include "model/test_record.h"
#include "model/rocking_model.h"

namespace rocklab::test {

inline constexpr double kDeg = 3.14159265358979323846 / 180.0;

/// Free rocking: the block is held at theta0 for hold_s, then released; the
/// record runs to hold_s + duration_s at rate_hz with N(0, noise_deg) noise.
inline model::RockingRecord SyntheticFree(const model::BlockParams& truth, double theta0,
                                          double hold_s, double duration_s, double rate_hz,
                                          double noise_deg, std::uint32_t seed,
                                          const std::string& name = "synthetic-free") {
  model::ModelOptions mo;
  mo.rtol = 1e-10;
  auto m = model::RockingModel::Create(model::ModelKind::kHousner, truth, mo);
  const model::NoTableMotion zero;
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_deg * kDeg);
  model::RockingRecord r;
  r.source = name;
  const auto n = static_cast<long>(std::floor((hold_s + duration_s) * rate_hz));
  bool released = false;
  for (long k = 0; k <= n; ++k) {
    const double t = static_cast<double>(k) / rate_hz;
    double theta = theta0;
    if (t >= hold_s) {
      if (!released) {
        m->Reset(hold_s, theta0, 0.0);
        released = true;
      }
      m->AdvanceTo(t, zero);
      theta = m->state().theta;
    }
    r.time_s.push_back(t);
    r.theta.push_back(theta + noise(rng));
    r.line.push_back(k + 2);
  }
  return r;
}

/// Forced rocking from rest: the model driven by `excitation` (exact), the
/// record holding theta at rate_hz with noise and the table acceleration
/// sampled at table_rate_hz (exact values, as an accelerometer without noise).
inline model::RockingRecord SyntheticForced(const model::BlockParams& truth,
                                            const model::Excitation& excitation,
                                            double duration_s, double rate_hz,
                                            double table_rate_hz, double noise_deg,
                                            std::uint32_t seed) {
  model::ModelOptions mo;
  mo.rtol = 1e-10;
  auto m = model::RockingModel::Create(model::ModelKind::kHousner, truth, mo);
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_deg * kDeg);
  model::RockingRecord r;
  r.source = "synthetic-forced";
  m->Reset(0.0, 0.0, 0.0);
  const auto n = static_cast<long>(std::floor(duration_s * rate_hz));
  for (long k = 0; k <= n; ++k) {
    const double t = static_cast<double>(k) / rate_hz;
    m->AdvanceTo(t, excitation);
    r.time_s.push_back(t);
    r.theta.push_back(m->state().theta + noise(rng));
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
