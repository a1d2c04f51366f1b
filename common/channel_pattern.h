#pragma once
/// @file
/// A user's channel pattern (`--channels`, Python's `channels=`) compiled
/// with bounds: std::regex compiles and matches by recursion, so a pattern
/// 30 000 groups deep overflowed the stack (issue 34).

#include <cstddef>
#include <regex>
#include <string>

namespace rocklab::common {

/// A channel pattern may be this long, and its groups nested this deep.
inline constexpr std::size_t kMaxChannelPatternBytes = 1024;
inline constexpr int kMaxChannelPatternDepth = 32;

/// Compiles a channel pattern (ECMAScript syntax).
/// @throws std::invalid_argument "<what>: ..." quoting the pattern (escaped,
///         cut) when it is too long, nested too deep or not a regex.
std::regex ChannelPattern(const std::string& pattern, const std::string& what);

}  // namespace rocklab::common
