#pragma once
/// @file
/// Text helpers for the readers of configuration and record files (not for
/// per-sample hot paths).

#include <string>
#include <string_view>

namespace rocklab::common {

/// `s` without surrounding spaces, tabs, '\r' and '\n'.
std::string_view Trim(std::string_view s);

/// Parses the whole of `field` as a double ("nan" and "inf" parse).
/// @return false when the field is empty or not entirely a number (`out`
///         is then unspecified).
bool ParseDouble(std::string_view field, double& out);

}  // namespace rocklab::common
