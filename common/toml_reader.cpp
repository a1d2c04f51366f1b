#include "common/toml_reader.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <sstream>
#include <stdexcept>

#include "common/text.h"

namespace rocklab::common {

// UTF-8 checked first: toml++ is not trusted with anything else (its
// header-only build reaches an "unreachable" on some invalid sequences).
toml::table ParseTomlText(const std::string& text, const std::string& path, const std::string& what) {
  if (const std::size_t bad = Utf8ValidPrefix(text); bad < text.size()) {
    const std::size_t line_start = bad == 0 ? std::string::npos : text.rfind('\n', bad - 1);
    const std::size_t column = bad - (line_start == std::string::npos ? 0 : line_start + 1) + 1;
    const auto line = 1 + std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(bad), '\n');
    char byte[8];
    std::snprintf(byte, sizeof byte, "0x%02x", static_cast<unsigned char>(text[bad]));
    std::ostringstream msg;
    msg << path << ":" << line << ": " << what << " is not valid UTF-8 (byte " << byte << " at column " << column
        << ")";
    throw std::runtime_error(msg.str());
  }
  toml::table root;
  try {
    root = toml::parse(text, path);
  } catch (const toml::parse_error& e) {
    std::ostringstream msg;
    msg << path << ":" << e.source().begin.line << ": " << Escape(e.description());  // may echo input
    throw std::runtime_error(msg.str());
  }
  return root;
}

void TomlReader::Fail(int line, const std::string& key, const std::string& what) const {
  std::ostringstream msg;
  msg << path_ << ":" << line << ": key " << Quote(key) << " " << what;  // keys come from the file
  throw std::runtime_error(msg.str());
}

const toml::node* TomlReader::Get(const toml::table& table, const std::string& prefix, const std::string& key) {
  seen_.insert(Join(prefix, key));
  return table.get(key);
}

double TomlReader::Double(const toml::table& table, const std::string& prefix, const std::string& key,
                          std::optional<double> fallback) {
  const toml::node* node = Get(table, prefix, key);
  if (node == nullptr) {
    if (fallback) return *fallback;
    Fail(LineOf(table), Join(prefix, key), "is missing");
  }
  if (auto v = node->value<double>()) {  // toml++ converts integers too
    if (!std::isfinite(*v)) Fail(LineOf(*node), Join(prefix, key), "must be finite");
    return *v;
  }
  Fail(LineOf(*node), Join(prefix, key), "must be a number");
}

std::optional<double> TomlReader::OptionalDouble(const toml::table& table, const std::string& prefix,
                                                 const std::string& key) {
  if (table.get(key) == nullptr) {
    seen_.insert(Join(prefix, key));
    return std::nullopt;
  }
  return Double(table, prefix, key, std::nullopt);
}

int TomlReader::Int(const toml::table& table, const std::string& prefix, const std::string& key,
                    std::optional<int> fallback, int lo, int hi) {
  const toml::node* node = Get(table, prefix, key);
  if (node == nullptr) {
    if (fallback) return *fallback;
    Fail(LineOf(table), Join(prefix, key), "is missing");
  }
  const std::string range = "[" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  if (!node->is_integer()) Fail(LineOf(*node), Join(prefix, key), "must be an integer in " + range);
  const int64_t v = *node->value<int64_t>();
  if (v < lo || v > hi) Fail(LineOf(*node), Join(prefix, key), "must be in " + range + ", got " + std::to_string(v));
  return static_cast<int>(v);
}

double TomlReader::Bounded(const toml::table& table, const std::string& prefix, const std::string& key,
                           std::optional<double> fallback, double lo, double hi, const char* unit) {
  const double v = Double(table, prefix, key, fallback);
  if (!(v >= lo && v <= hi)) {
    std::ostringstream msg;
    msg << "must be in [" << lo << ", " << hi << "]" << unit << ", got " << v;
    const toml::node* node = table.get(key);
    Fail(node != nullptr ? LineOf(*node) : LineOf(table), Join(prefix, key), msg.str());
  }
  return v;
}

std::string TomlReader::String(const toml::table& table, const std::string& prefix, const std::string& key,
                               std::optional<std::string> fallback) {
  const toml::node* node = Get(table, prefix, key);
  if (node == nullptr) {
    if (fallback) return *fallback;
    Fail(LineOf(table), Join(prefix, key), "is missing");
  }
  if (!node->is_string()) Fail(LineOf(*node), Join(prefix, key), "must be a string");
  return *node->value<std::string>();
}

const toml::table* TomlReader::Table(const toml::table& table, const std::string& prefix, const std::string& key,
                                     bool required) {
  const toml::node* node = Get(table, prefix, key);
  if (node == nullptr) {
    if (required) Fail(LineOf(table), Join(prefix, key), "is missing");
    return nullptr;
  }
  if (!node->is_table()) Fail(LineOf(*node), Join(prefix, key), "must be a table");
  return node->as_table();
}

const toml::array* TomlReader::Array(const toml::table& table, const std::string& prefix, const std::string& key) {
  const toml::node* node = Get(table, prefix, key);
  if (node == nullptr) return nullptr;
  if (!node->is_array()) Fail(LineOf(*node), Join(prefix, key), "must be an array");
  return node->as_array();
}

void TomlReader::Check(bool ok, const toml::table& table, const std::string& prefix, const std::string& key,
                       const std::string& what) const {
  if (ok) return;
  const toml::node* node = table.get(key);
  Fail(node != nullptr ? LineOf(*node) : LineOf(table), Join(prefix, key), what);
}

void TomlReader::RejectUnknown(const toml::table& table, const std::string& prefix) const {
  for (const auto& [k, v] : table) {
    const std::string key = Join(prefix, std::string(k.str()));
    if (seen_.count(key) == 0) Fail(LineOf(v), key, "is not " + kind_ + " key");
  }
}

}  // namespace rocklab::common
