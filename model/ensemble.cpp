#include "model/ensemble.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <string_view>

#include "common/text.h"
#include "common/units.h"

namespace rocklab::model {
namespace {

using common::kNaN;

std::string Where(const std::string& path, int line) { return path + ":" + std::to_string(line); }

}  // namespace

std::vector<PosteriorDraw> ReadPosteriorSamples(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument("posterior samples '" + path + "': cannot read the file");
  std::string text;
  std::vector<std::string_view> fields;
  int line = 0;
  // Column index of each parameter; -1 until the header names it.
  int col_alpha = -1, col_p = -1, col_mu = -1, col_l = -1, col_sigma = -1;
  std::size_t columns = 0;
  bool have_header = false;
  std::vector<PosteriorDraw> draws;
  while (std::getline(in, text)) {
    ++line;
    if (line == 1) common::StripByteOrderMark(text);
    const std::string_view trimmed = common::Trim(text);
    if (trimmed.empty() || trimmed.front() == '#') continue;
    common::Split(trimmed, ',', fields);
    if (!have_header) {
      have_header = true;
      columns = fields.size();
      for (std::size_t i = 0; i < fields.size(); ++i) {
        const std::string_view name = common::Trim(fields[i]);
        int* slot = name == "alpha" ? &col_alpha : name == "p" ? &col_p : name == "mu" ? &col_mu
                    : name == "l" ? &col_l : name == "sigma" ? &col_sigma : nullptr;
        if (slot == nullptr) continue;
        if (*slot >= 0) {
          throw std::invalid_argument(Where(path, line) + ": column '" + std::string(name) +
                                      "' named twice (columns " + std::to_string(*slot + 1) + " and " +
                                      std::to_string(i + 1) + ")");
        }
        *slot = static_cast<int>(i);
      }
      for (const auto& [col, name] : {std::pair{col_alpha, "alpha"}, {col_p, "p"}, {col_mu, "mu"}}) {
        if (col < 0) {
          throw std::invalid_argument(Where(path, line) + ": the header has no column '" + name +
                                      "' (expected alpha, p, mu [, l] and others)");
        }
      }
      continue;
    }
    if (fields.size() != columns) {
      throw std::invalid_argument(Where(path, line) + ": " + std::to_string(fields.size()) +
                                  " fields, the header has " + std::to_string(columns));
    }
    auto number = [&](int col, const char* name) {
      double v = 0;
      const std::string_view f = fields[static_cast<std::size_t>(col)];
      if (!common::ParseDouble(f, v) || !std::isfinite(v)) {
        throw std::invalid_argument(Where(path, line) + ", column " + std::to_string(col + 1) + " (" +
                                    name + "): " + common::Quote(f) + " is not a finite number");
      }
      return v;
    };
    PosteriorDraw d;
    d.params = BlockParams{number(col_alpha, "alpha"), number(col_p, "p"), number(col_mu, "mu")};
    d.l = col_l >= 0 ? number(col_l, "l") : kNaN;
    d.sigma = col_sigma >= 0 ? number(col_sigma, "sigma") : 0.0;
    d.line = line;
    try {
      d.params.Validate();
      if (col_l >= 0 && !(d.l > 0)) throw std::invalid_argument("l must be > 0");
      if (col_sigma >= 0 && !(d.sigma > 0)) throw std::invalid_argument("sigma must be > 0 rad");
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(Where(path, line) + ": " + e.what());
    }
    draws.push_back(d);
  }
  if (!have_header) throw std::invalid_argument("posterior samples '" + path + "': empty file (no header)");
  if (draws.empty()) throw std::invalid_argument("posterior samples '" + path + "': no draw after the header");
  return draws;
}

std::vector<std::size_t> PickDraws(std::size_t n, int k) {
  if (k < 1) throw std::invalid_argument("ensemble size must be >= 1");
  if (n < 1) throw std::invalid_argument("no draws to pick from");
  const std::size_t kk = std::min(n, static_cast<std::size_t>(k));
  std::vector<std::size_t> rows(kk);
  // In integers: i n / k < n exactly, no rounding to decide.
  for (std::size_t i = 0; i < kk; ++i) rows[i] = i * n / kk;
  return rows;
}

void EnsembleSpec::Validate() const {
  if (name.empty()) throw std::invalid_argument("ensemble: empty name");
  for (char ch : name) {
    if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '_') {
      throw std::invalid_argument("ensemble '" + name + "': the name may hold only letters, digits and _");
    }
  }
  if (draws.empty()) throw std::invalid_argument("ensemble '" + name + "': no draws");
  options.Validate();
}

EnsembleSpec MakeEnsemble(const std::string& name, ModelKind kind, const std::string& path, int k,
                          const ModelOptions& options) {
  EnsembleSpec e;
  e.name = name;
  e.kind = kind;
  e.options = options;
  e.source = path;
  const std::vector<PosteriorDraw> all = ReadPosteriorSamples(path);
  for (std::size_t row : PickDraws(all.size(), k)) e.draws.push_back(all[row]);
  e.Validate();
  return e;
}

double SortedQuantile(const std::vector<double>& sorted, double q) {
  const double h = static_cast<double>(sorted.size() - 1) * q;
  const double lo = std::floor(h);
  const auto i = static_cast<std::size_t>(lo);
  if (i + 1 >= sorted.size()) return sorted.back();
  return sorted[i] + (h - lo) * (sorted[i + 1] - sorted[i]);
}

BandQuantiles ComputeBand(std::vector<double>& values) {
  if (values.empty()) return {kNaN, kNaN, kNaN, kNaN, kNaN};
  std::sort(values.begin(), values.end());
  return {SortedQuantile(values, 0.025), SortedQuantile(values, 0.16), SortedQuantile(values, 0.5),
          SortedQuantile(values, 0.84), SortedQuantile(values, 0.975)};
}

BandQuantiles ComputeNoisyBand(const std::vector<double>& values, const std::vector<double>& sigmas) {
  const std::size_t n = values.size();
  if (n == 0) return {kNaN, kNaN, kNaN, kNaN, kNaN};
  double lo = values[0], hi = values[0], max_sigma = 0;
  for (std::size_t k = 0; k < n; ++k) {
    lo = std::min(lo, values[k]);
    hi = std::max(hi, values[k]);
    max_sigma = std::max(max_sigma, sigmas[k]);
  }
  // F(x) - q and its derivative, the mixture's density.
  constexpr double kInvSqrt2 = 0.70710678118654752440;
  constexpr double kInvSqrt2Pi = 0.39894228040143267794;
  auto solve = [&](double q) {
    double a = lo - 9 * max_sigma, b = hi + 9 * max_sigma;  // F(a) < q < F(b) for q in [0.025, 0.975]
    double x = 0;
    for (std::size_t k = 0; k < n; ++k) x += values[k];
    x /= static_cast<double>(n);
    for (int it = 0; it < 200; ++it) {
      double f = 0, dens = 0;
      for (std::size_t k = 0; k < n; ++k) {
        const double z = (x - values[k]) / sigmas[k];
        f += 0.5 * std::erfc(-z * kInvSqrt2);
        dens += kInvSqrt2Pi * std::exp(-0.5 * z * z) / sigmas[k];
      }
      f = f / static_cast<double>(n) - q;
      dens /= static_cast<double>(n);
      if (f < 0) a = x; else b = x;
      double next = dens > 0 ? x - f / dens : 0.5 * (a + b);
      if (!(next > a && next < b)) next = 0.5 * (a + b);  // Newton left the bracket: bisect
      if (std::abs(next - x) <= 1e-12 || b - a <= 1e-12) return next;
      x = next;
    }
    return x;
  };
  return {solve(0.025), solve(0.16), solve(0.5), solve(0.84), solve(0.975)};
}

}  // namespace rocklab::model
