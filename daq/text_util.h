#pragma once
// Private to rocklab::daq: allocation-free field splitting and number parsing
// for the text sources.

#include <string>
#include <string_view>
#include <vector>

namespace rocklab::daq::detail {

/// Whether `path` ends with `extension` (e.g. ".lvm"), ignoring ASCII case.
bool HasExtension(const std::string& path, const std::string& extension);

/// Removes surrounding spaces, tabs and a trailing '\r'.
std::string_view Trim(std::string_view s);

/// Splits `line` at `sep` into `fields` (cleared first; capacity is reused).
void Split(std::string_view line, char sep, std::vector<std::string_view>& fields);

/// Parses a whole field as a double ("nan" and "inf" accepted, a leading '+'
/// too). With decimal_comma, ',' is the decimal separator ('.' is rejected).
/// Returns false when the field is empty or not entirely a number.
bool ParseNumber(std::string_view field, bool decimal_comma, double& out);

}  // namespace rocklab::daq::detail
