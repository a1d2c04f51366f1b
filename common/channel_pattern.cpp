#include "common/channel_pattern.h"

#include <algorithm>
#include <stdexcept>

#include "common/text.h"

namespace rocklab::common {

std::regex ChannelPattern(const std::string& pattern, const std::string& what) {
  if (pattern.size() > kMaxChannelPatternBytes) {
    throw std::invalid_argument(what + ": the pattern " + Quote(pattern) + " is longer than " +
                                std::to_string(kMaxChannelPatternBytes) + " bytes");
  }
  // Depth of ( and [ outside escapes; brackets do not nest, groups do.
  int depth = 0, deepest = 0;
  bool escaped = false, in_class = false;
  for (char c : pattern) {
    if (escaped) {
      escaped = false;
    } else if (c == '\\') {
      escaped = true;
    } else if (in_class) {
      in_class = c != ']';
    } else if (c == '[') {
      in_class = true;
    } else if (c == '(') {
      deepest = std::max(deepest, ++depth);
    } else if (c == ')') {
      --depth;
    }
  }
  if (deepest > kMaxChannelPatternDepth) {
    throw std::invalid_argument(what + ": the pattern " + Quote(pattern) + " nests groups " +
                                std::to_string(deepest) + " deep, more than " +
                                std::to_string(kMaxChannelPatternDepth));
  }
  try {
    return std::regex(pattern);
  } catch (const std::regex_error& e) {
    throw std::invalid_argument(what + ": not a regular expression " + Quote(pattern) + ": " + e.what());
  }
}

}  // namespace rocklab::common
