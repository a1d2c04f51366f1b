#pragma once
// Private to rocklab::model: constants and number formatting shared by the
// model sources (error messages print values with all 17 digits).

#include <sstream>
#include <string>

namespace rocklab::model::detail {

inline constexpr double kPi = 3.14159265358979323846;

/// `v` with 17 significant digits, so a message shows the exact value.
inline std::string ExactText(double v) {
  std::ostringstream out;
  out.precision(17);
  out << v;
  return out.str();
}

}  // namespace rocklab::model::detail
