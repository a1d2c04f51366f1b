#pragma once
// Reading a TOML configuration file (the rig file, an assembly file) with
// toml++: the text checked as UTF-8 and parsed, then keys read out of it
// with every error naming the file, the line and the key, and keys nobody
// read rejected (a typo must not be silently ignored). Not installed: the
// libraries that read TOML link toml++ themselves.
#include <optional>
#include <set>
#include <string>

#include <toml++/toml.h>

namespace rocklab::common {

/// The text of `path` as a TOML table. `what` names the file in the UTF-8
/// error ("the rig file is not valid UTF-8 ..."). @throws std::runtime_error
/// "PATH:LINE: ..." for invalid UTF-8 or TOML.
toml::table ParseTomlText(const std::string& text, const std::string& path, const std::string& what);

class TomlReader {
 public:
  /// `kind` completes "is not KIND key" for an unknown key ("a rig configuration").
  TomlReader(std::string path, std::string kind) : path_(std::move(path)), kind_(std::move(kind)) {}

  /// @throws std::runtime_error "PATH:LINE: key 'KEY' WHAT".
  [[noreturn]] void Fail(int line, const std::string& key, const std::string& what) const;
  static int LineOf(const toml::node& node) { return static_cast<int>(node.source().begin.line); }

  /// The node at `key` (nullptr when absent), marked as read.
  const toml::node* Get(const toml::table& table, const std::string& prefix, const std::string& key);
  /// A finite number (an integer is taken too); `fallback` when absent, else missing fails.
  double Double(const toml::table& table, const std::string& prefix, const std::string& key,
                std::optional<double> fallback);
  std::optional<double> OptionalDouble(const toml::table& table, const std::string& prefix, const std::string& key);
  /// An integer in [lo, hi], checked before it is narrowed (4294967298 must not become 2).
  int Int(const toml::table& table, const std::string& prefix, const std::string& key, std::optional<int> fallback,
          int lo, int hi);
  /// A number in [lo, hi] (`unit` names the unit in the message).
  double Bounded(const toml::table& table, const std::string& prefix, const std::string& key,
                 std::optional<double> fallback, double lo, double hi, const char* unit);
  std::string String(const toml::table& table, const std::string& prefix, const std::string& key,
                     std::optional<std::string> fallback);
  const toml::table* Table(const toml::table& table, const std::string& prefix, const std::string& key,
                           bool required);
  const toml::array* Array(const toml::table& table, const std::string& prefix, const std::string& key);
  /// Fails at `key`'s line (the table's when it is absent) unless `ok`.
  void Check(bool ok, const toml::table& table, const std::string& prefix, const std::string& key,
             const std::string& what) const;
  /// Every key of `table` must have been read under `prefix`.
  void RejectUnknown(const toml::table& table, const std::string& prefix) const;

  static std::string Join(const std::string& prefix, const std::string& key) {
    return prefix.empty() ? key : prefix + "." + key;
  }

 private:
  std::string path_;
  std::string kind_;
  std::set<std::string> seen_;
};

}  // namespace rocklab::common
