#pragma once
// Private to rocklab::model: constants and number formatting shared by the
// model sources (error messages print values with all 17 digits).

#include <sstream>
#include <string>

#include "common/units.h"

namespace rocklab::model::detail {

using common::kPi;  // written once, in common/units.h

/// `v` with 17 significant digits, so a message shows the exact value.
inline std::string ExactText(double v) {
  std::ostringstream out;
  out.precision(17);
  out << v;
  return out.str();
}

}  // namespace rocklab::model::detail
