#include "common/text.h"

#include <cstdlib>

namespace rocklab::common {

std::string_view Trim(std::string_view s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string_view::npos) return {};
  const auto e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}

bool ParseDouble(std::string_view field, double& out) {
  if (field.empty()) return false;
  const std::string text(field);  // strtod needs a terminated string
  char* end = nullptr;
  out = std::strtod(text.c_str(), &end);
  return end == text.c_str() + text.size();
}

}  // namespace rocklab::common
