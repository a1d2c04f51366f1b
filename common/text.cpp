#include "common/text.h"

#include <algorithm>
#include <cctype>
#include <cstdarg>
#include <cstdio>
#include <atomic>
#include <charconv>
#include <mutex>
#include <utility>
#include <vector>
#include <cstdint>

namespace rocklab::common {

std::string_view Trim(std::string_view s) {
  const auto blank = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; };
  while (!s.empty() && blank(s.front())) s.remove_prefix(1);
  while (!s.empty() && blank(s.back())) s.remove_suffix(1);
  return s;
}

void Split(std::string_view line, char sep, std::vector<std::string_view>& fields) {
  fields.clear();
  std::size_t start = 0;
  while (true) {
    const std::size_t end = line.find(sep, start);
    if (end == std::string_view::npos) {
      fields.push_back(line.substr(start));
      return;
    }
    fields.push_back(line.substr(start, end - start));
    start = end + 1;
  }
}

bool ParseNumber(std::string_view field, bool decimal_comma, double& out) {
  field = Trim(field);
  if (!field.empty() && field.front() == '+') field.remove_prefix(1);
  if (field.empty() || field.size() > 64) return false;
  const char* first = field.data();
  const char* last = field.data() + field.size();
  char buffer[64];
  if (decimal_comma) {
    // Swap the separators into a stack buffer: '.' is then not a number.
    std::size_t i = 0;
    for (char c : field) {
      if (c == '.') return false;
      buffer[i++] = (c == ',') ? '.' : c;
    }
    first = buffer;
    last = buffer + i;
  }
  const auto [ptr, ec] = std::from_chars(first, last, out);
  return ec == std::errc() && ptr == last;
}

namespace {

// Length of the well-formed UTF-8 sequence at text[i] (1 for ASCII) with its
// code point in `cp`; 0 when the bytes there are not one (RFC 3629).
std::size_t Utf8SequenceAt(std::string_view text, std::size_t i, uint32_t& cp) {
  const auto c = static_cast<unsigned char>(text[i]);
  if (c < 0x80) {
    cp = c;
    return 1;
  }
  std::size_t more = 0;
  if (c >= 0xC2 && c <= 0xDF) {
    more = 1;
    cp = c & 0x1F;
  } else if (c >= 0xE0 && c <= 0xEF) {
    more = 2;
    cp = c & 0x0F;
  } else if (c >= 0xF0 && c <= 0xF4) {
    more = 3;
    cp = c & 0x07;
  } else {
    return 0;
  }
  if (i + more >= text.size()) return 0;
  for (std::size_t k = 1; k <= more; ++k) {
    const auto d = static_cast<unsigned char>(text[i + k]);
    if ((d & 0xC0) != 0x80) return 0;
    cp = (cp << 6) | (d & 0x3F);
  }
  if ((more == 2 && cp < 0x800) || (more == 3 && (cp < 0x10000 || cp > 0x10FFFF)) ||
      (cp >= 0xD800 && cp <= 0xDFFF)) {
    return 0;
  }
  return more + 1;
}

}  // namespace

std::size_t Utf8ValidPrefix(std::string_view text) {
  std::size_t i = 0;
  uint32_t cp = 0;
  while (i < text.size()) {
    const std::size_t len = Utf8SequenceAt(text, i, cp);
    if (len == 0) return i;
    i += len;
  }
  return i;
}

bool IsUtf8(std::string_view text) { return Utf8ValidPrefix(text) == text.size(); }

std::string ToUtf8(std::string_view text) {
  if (IsUtf8(text)) return std::string(text);
  // Windows-1252's 0x80..0x9F; 0 where it defines no character.
  static const uint16_t k80[32] = {
      0x20AC, 0,      0x201A, 0x0192, 0x201E, 0x2026, 0x2020, 0x2021, 0x02C6, 0x2030, 0x0160,
      0x2039, 0x0152, 0,      0x017D, 0,      0,      0x2018, 0x2019, 0x201C, 0x201D, 0x2022,
      0x2013, 0x2014, 0x02DC, 0x2122, 0x0161, 0x203A, 0x0153, 0,      0x017E, 0x0178};
  std::string out;
  out.reserve(text.size() * 2);
  for (char ch : text) {
    const auto c = static_cast<unsigned char>(ch);
    uint32_t cp = c;
    if (c >= 0x80 && c <= 0x9F) cp = k80[c - 0x80] ? k80[c - 0x80] : 0xFFFD;
    if (cp < 0x80) {
      out += static_cast<char>(cp);
    } else if (cp < 0x800) {
      out += static_cast<char>(0xC0 | (cp >> 6));
      out += static_cast<char>(0x80 | (cp & 0x3F));
    } else {
      out += static_cast<char>(0xE0 | (cp >> 12));
      out += static_cast<char>(0x80 | ((cp >> 6) & 0x3F));
      out += static_cast<char>(0x80 | (cp & 0x3F));
    }
  }
  return out;
}

char SniffDelimiter(std::string_view header) {
  std::size_t tabs = 0, semis = 0, commas = 0;
  for (char c : header) {
    if (c == '\t') ++tabs;
    if (c == ';') ++semis;
    if (c == ',') ++commas;
  }
  if (tabs > 0 && tabs >= semis && tabs >= commas) return '\t';
  if (semis > 0 && semis >= commas) return ';';
  return ',';
}

std::string Format(const char* format, ...) {
  char buf[512];
  va_list args;
  va_start(args, format);
  std::vsnprintf(buf, sizeof buf, format, args);
  va_end(args);
  return buf;
}

bool HasExtension(std::string_view path, std::string_view extension) {
  if (path.size() < extension.size()) return false;
  const std::size_t start = path.size() - extension.size();
  for (std::size_t i = 0; i < extension.size(); ++i) {
    if (std::tolower(static_cast<unsigned char>(path[start + i])) !=
        std::tolower(static_cast<unsigned char>(extension[i]))) {
      return false;
    }
  }
  return true;
}

namespace {

// Appends `text` to `out` escaped, taking at most `max_bytes` of it (never a
// split character) and then " ... [N bytes more]". Printable ASCII is kept;
// with `utf8`, well-formed UTF-8 characters from U+00A0 up too, except the
// bidirectional overrides. Without `utf8` (Quote, Escape) backslash is
// escaped as "\\", with `quote` the single quote too. Every other byte
// becomes \xNN. Printable leaves backslash alone so that its own escapes
// pass a second Printable unchanged.
void AppendEscaped(std::string& out, std::string_view text, std::size_t max_bytes, bool utf8, bool quote) {
  static const char kHex[] = "0123456789abcdef";
  const auto hex = [&out](unsigned char c) {
    out += "\\x";
    out += kHex[c >> 4];
    out += kHex[c & 0xf];
  };
  std::size_t i = 0;
  while (i < text.size()) {
    const auto c = static_cast<unsigned char>(text[i]);
    uint32_t cp = 0;
    const std::size_t len = c < 0x80 ? 1 : (utf8 ? Utf8SequenceAt(text, i, cp) : 0);
    if (i + std::max<std::size_t>(len, 1) > max_bytes) break;
    if ((!utf8 && c == '\\') || (quote && c == '\'')) {
      out += '\\';
      out += static_cast<char>(c);
    } else if (c >= 0x20 && c < 0x7f) {
      out += static_cast<char>(c);
    } else if (len > 1 && cp >= 0xA0 && !(cp >= 0x202A && cp <= 0x202E) && !(cp >= 0x2066 && cp <= 0x2069)) {
      out.append(text.substr(i, len));
    } else {
      for (std::size_t k = 0; k < std::max<std::size_t>(len, 1); ++k) hex(static_cast<unsigned char>(text[i + k]));
    }
    i += std::max<std::size_t>(len, 1);
  }
  if (i < text.size()) out += " ... [" + std::to_string(text.size() - i) + " bytes more]";
}

}  // namespace

std::string Quote(std::string_view text, std::size_t max_bytes) {
  std::string out = "'";
  const std::size_t n = std::min(text.size(), max_bytes);
  AppendEscaped(out, text.substr(0, n), n, false, true);
  out += '\'';
  if (n < text.size()) out += " ... [" + std::to_string(text.size() - n) + " bytes more]";
  return out;
}

std::string Escape(std::string_view text) {
  std::string out;
  AppendEscaped(out, text, text.size(), false, false);
  return out;
}

std::string XmlText(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '&': out += "&amp;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

namespace {
// ShowPathAs's pairs (path, shown); `g_path_aliases_set` spares the lock
// while there are none (every program but the CLI given `-`).
std::mutex g_path_aliases_mutex;
std::vector<std::pair<std::string, std::string>> g_path_aliases;
std::atomic<bool> g_path_aliases_set{false};

}  // namespace

std::string WithPathsShown(std::string_view text) {
  std::string s(text);
  if (!g_path_aliases_set.load(std::memory_order_relaxed)) return s;
  const std::lock_guard<std::mutex> lock(g_path_aliases_mutex);
  for (const auto& alias : g_path_aliases) {
    for (std::size_t at = s.find(alias.first); at != std::string::npos;
         at = s.find(alias.first, at + alias.second.size())) {
      s.replace(at, alias.first.size(), alias.second);
    }
  }
  return s;
}

void ShowPathAs(const std::string& path, const std::string& shown) {
  if (path.empty()) return;
  const std::lock_guard<std::mutex> lock(g_path_aliases_mutex);
  g_path_aliases.emplace_back(path, shown);
  g_path_aliases_set.store(true);
}

std::string Printable(std::string_view text, std::size_t max_bytes) {
  std::string shown;  // a temporary named as what the user gave (ShowPathAs)
  if (g_path_aliases_set.load(std::memory_order_relaxed)) text = shown = WithPathsShown(text);
  std::string out;
  out.reserve(std::min(text.size(), max_bytes) + 32);
  AppendEscaped(out, text, max_bytes, true, false);
  return out;
}

std::string PrintableLines(std::string_view text, std::size_t max_line_bytes) {
  std::string out;
  while (true) {
    const std::size_t nl = text.find('\n');
    out += Printable(text.substr(0, nl), max_line_bytes);
    if (nl == std::string_view::npos) return out;
    out += '\n';
    text.remove_prefix(nl + 1);
  }
}

bool StripByteOrderMark(std::string& line) {
  if (line.size() >= 3 && line.compare(0, 3, "\xEF\xBB\xBF") == 0) {
    line.erase(0, 3);
    return true;
  }
  return false;
}

}  // namespace rocklab::common
