#pragma once
// Private to rocklab::daq: allocation-free field splitting and number parsing
// for the text sources.

#include <cstddef>
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

/// Bytes of input a message quotes at most (Quote).
inline constexpr std::size_t kMaxQuotedBytes = 48;

/// `text` in single quotes for a message: printable ASCII as is, backslash
/// and quote escaped, every other byte (NUL, control, non-ASCII) as \xNN;
/// at most `max_bytes` bytes of it, then "..." and the full size in bytes.
/// A message built with it is one line of plain ASCII whatever the input.
std::string Quote(std::string_view text, std::size_t max_bytes = kMaxQuotedBytes);

/// Removes a UTF-8 byte order mark (EF BB BF) from the start of `line`.
/// Returns whether there was one.
bool StripByteOrderMark(std::string& line);

}  // namespace rocklab::daq::detail
