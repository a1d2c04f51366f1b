#pragma once
// Synthetic ground motions the sweep tests write for themselves (PEER's
// records may not be redistributed): pulses in closed form and filtered
// noise from a seeded generator; a results CSV without its provenance.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace rocklab::test {

/// A sweep's CSV without its provenance lines (sweep::ProvenanceText): what
/// differs, by design, between runs and shards of one sweep.
inline std::string WithoutProvenanceLines(const std::string& csv) {
  std::istringstream in(csv);
  std::string out;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("# rocklab provenance", 0) == 0 || line.rfind("# provenance.", 0) == 0) continue;
    out += line + "\n";
  }
  return out;
}

/// Writes `time,accel` rows of accel(t) (m/s^2) at t = k dt, k = 0..round(T / dt).
inline void WriteRecord(const std::string& path, double duration_s, double dt_s,
                        const std::function<double(double)>& accel) {
  std::FILE* f = std::fopen(path.c_str(), "w");
  if (!f) throw std::runtime_error("cannot write " + path);
  std::fprintf(f, "time,accel\n");
  const long n = std::lround(duration_s / dt_s);
  for (long k = 0; k <= n; ++k) {
    const double t = static_cast<double>(k) * dt_s;
    std::fprintf(f, "%.17g,%.17g\n", t, accel(t));
  }
  std::fclose(f);
}

/// Filtered noise: white noise from a seeded linear congruential generator
/// through two one-pole low-pass stages at about `corner_hz`, under a
/// sine-squared envelope, scaled to the peak `peak_mps2`.
inline void WriteFilteredNoise(const std::string& path, std::uint64_t seed, double duration_s, double dt_s,
                               double corner_hz, double peak_mps2) {
  std::uint64_t state = seed * 2862933555777941757ull + 3037000493ull;
  auto uniform = [&state] {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<double>(state >> 11) / 9007199254740992.0 - 0.5;
  };
  const double w = 2 * 3.14159265358979323846 * corner_hz * dt_s;
  double y1 = 0, y2 = 0;
  const long n = std::lround(duration_s / dt_s);
  double peak = 0;
  std::vector<double> v(static_cast<std::size_t>(n) + 1);
  for (long k = 0; k <= n; ++k) {
    y1 += w * (uniform() - y1);
    y2 += w * (y1 - y2);
    const double env = std::pow(std::sin(3.14159265358979323846 * static_cast<double>(k) / static_cast<double>(n)), 2);
    v[static_cast<std::size_t>(k)] = env * y2;
    peak = std::max(peak, std::abs(v[static_cast<std::size_t>(k)]));
  }
  WriteRecord(path, duration_s, dt_s, [&](double t) {
    return peak_mps2 / peak * v[static_cast<std::size_t>(std::lround(t / dt_s))];
  });
}

}  // namespace rocklab::test
