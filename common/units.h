#pragma once
/// @file
/// Constants and unit conversions, written once for every library. SI inside
/// the code; degrees only for what people read (tables, pages, figures).

#include <limits>

namespace rocklab::common {

inline constexpr double kPi = 3.14159265358979323846;
/// Standard gravity as the paper uses it, m/s^2.
inline constexpr double kGravity = 9.81;
/// Degrees per radian.
inline constexpr double kDegPerRad = 180.0 / kPi;
/// Quiet NaN: "no value" in a double (a missing sample, an undefined result).
inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

}  // namespace rocklab::common
