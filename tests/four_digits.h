#pragma once
// The browser tests' check of a number the page prints with 4 significant
// digits (its %.4g), shared by the monitor's and the report's tests.

#include <cmath>
#include <cstdlib>
#include <string>

namespace rocklab::test {

/// |shown - exact| within half a unit of the 4th significant digit of exact
/// (plus a relative 1e-12 for the decimal-binary round trip).
inline bool SameAtFourDigits(const std::string& shown, double exact) {
  char* end = nullptr;
  const double value = std::strtod(shown.c_str(), &end);
  if (end == shown.c_str() || *end != '\0') return false;
  if (exact == 0) return value == 0;
  const double unit = std::pow(10.0, std::floor(std::log10(std::fabs(exact))) - 3);
  return std::fabs(value - exact) <= 0.5 * unit + 1e-12 * std::fabs(exact);
}

}  // namespace rocklab::test
