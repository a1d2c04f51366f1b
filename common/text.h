#pragma once
/// @file
/// Text helpers written once for every reader of text input: the DAQ's CSV
/// and LVM sources and rig file, the model's records, variants and
/// excitation specs. Trim, Split and ParseNumber never allocate (the DAQ
/// sources call them per sample); Quote builds messages about bad input.

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace rocklab::common {

/// `s` without surrounding spaces, tabs, '\r' and '\n'.
std::string_view Trim(std::string_view s);

/// Whether `s` begins with `prefix`.
inline bool StartsWith(std::string_view s, std::string_view prefix) {
  return s.substr(0, prefix.size()) == prefix;
}

/// Splits `line` at `sep` into `fields` (cleared first; capacity is reused).
void Split(std::string_view line, char sep, std::vector<std::string_view>& fields);

/// Parses the whole of `field` (surrounding blanks trimmed) as a double:
/// "nan" and "inf" parse, a leading '+' too; more than 64 bytes or a value
/// out of range does not. With decimal_comma, ',' is the decimal separator
/// ('.' is then rejected). Never allocates.
/// @return false when the field is empty or not entirely a number (`out`
///         is then unspecified).
bool ParseNumber(std::string_view field, bool decimal_comma, double& out);

/// ParseNumber with '.' as the decimal separator.
inline bool ParseDouble(std::string_view field, double& out) {
  return ParseNumber(field, false, out);
}

/// printf into a string (at most 511 bytes; longer output is cut), for the
/// text reports of `info` and `report`.
std::string Format(const char* format, ...) __attribute__((format(printf, 1, 2)));

/// Whether `path` ends with `extension` (e.g. ".lvm"), ignoring ASCII case.
bool HasExtension(std::string_view path, std::string_view extension);

/// Bytes of input a message quotes at most (Quote).
inline constexpr std::size_t kMaxQuotedBytes = 48;

/// `text` in single quotes for a message: printable ASCII as is, backslash
/// and quote escaped, every other byte (NUL, control, non-ASCII) as \xNN;
/// at most `max_bytes` bytes of it, then " ... [N bytes more]" (as
/// Printable). A message built with it is one line of plain ASCII whatever
/// the input.
std::string Quote(std::string_view text, std::size_t max_bytes = kMaxQuotedBytes);

/// `text` escaped as Quote does, without the quotes and the bound: for a
/// message a library wrote about input (it may echo the input's bytes).
std::string Escape(std::string_view text);

/// `text` as XML/HTML element content or a double-quoted attribute value:
/// `<`, `>`, `&` and `"` as entities, every other byte as it is.
std::string XmlText(std::string_view text);

/// Bytes of one line that Printable keeps by default: a line of a message
/// or log that carries text from a file or the network holds at most this
/// many bytes of it (plus escapes and the cut notice); docs/reliability.md.
inline constexpr std::size_t kMaxLineBytes = 4096;

/// `text` made safe for a terminal or a log, the one rule for every line
/// that carries text from a file or the network: printable ASCII and
/// well-formed UTF-8 characters from U+00A0 up are kept; every other byte
/// becomes "\xNN": NUL, the C0 controls (ESC, TAB, CR, LF, ...), DEL, the
/// C1 controls U+0080..U+009F (a terminal may obey them), the bidirectional
/// overrides U+202A..U+202E and U+2066..U+2069, and bytes that are not
/// well-formed UTF-8. The result is one line of well-formed UTF-8 whose
/// escapes are not escaped again by a second Printable.
/// When `text` is longer than `max_bytes`, its first `max_bytes` bytes (a
/// character is never split) are kept and " ... [N bytes more]" names the
/// bytes left out.
std::string Printable(std::string_view text, std::size_t max_bytes = kMaxLineBytes);

/// Printable applied to each '\n'-separated line of a message, the line
/// breaks kept: for a whole message a command prints or Python raises,
/// whose own words may span lines but whose input must not.
std::string PrintableLines(std::string_view text, std::size_t max_line_bytes = kMaxLineBytes);

/// A file that stands in for what the user gave (standard input copied to
/// a temporary file by the CLI): from now on Printable and PrintableLines
/// show `shown` (e.g. "<stdin>") wherever `path` occurs, so errors and log
/// lines name the input the user gave, not the temporary. Thread-safe.
void ShowPathAs(const std::string& path, const std::string& shown);

/// `text` with every path given to ShowPathAs replaced by its shown name
/// (provenance's source names; Printable does it itself).
std::string WithPathsShown(std::string_view text);

/// Whether `text` is well-formed UTF-8 (no overlong forms, no surrogates).
bool IsUtf8(std::string_view text);

/// Bytes of `text` before its first byte that is not well-formed UTF-8 (the
/// start of an invalid or cut sequence); text.size() when it all is.
std::size_t Utf8ValidPrefix(std::string_view text);

/// `text` as UTF-8 when it is, else read as Windows-1252 (a superset of the
/// printable Latin-1 that LabVIEW on Windows writes) and transcoded: 0xE3
/// becomes U+00E3, 0xB0 U+00B0, 0x80 U+20AC; the five bytes Windows-1252
/// leaves undefined become U+FFFD.
std::string ToUtf8(std::string_view text);

/// The field separator of a delimited header line: tab, ';' or ',',
/// whichever occurs most (ties: tab, then ';', then ','); ',' when none does.
char SniffDelimiter(std::string_view header);

/// Removes a UTF-8 byte order mark (EF BB BF) from the start of `line`.
/// @return whether there was one.
bool StripByteOrderMark(std::string& line);

}  // namespace rocklab::common
