// `rocklab daq --config FILE.toml`: every option of `rocklab daq` as a key
// (the flag's name without its dashes), read with toml++ as the rig file is:
// every error names the file, the line and the key. A flag given on the
// command line overrides its key.
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <toml++/toml.h>

#include "pipeline/pipeline.h"

namespace rocklab::pipeline {
namespace {

[[noreturn]] void Fail(const std::string& path, const toml::node& node, const std::string& key,
                       const std::string& what) {
  std::ostringstream msg;
  msg << path << ":" << node.source().begin.line << ": key '" << key << "' " << what;
  throw OptionError(msg.str());
}

std::string String(const std::string& path, const toml::node& node, const std::string& key) {
  const auto v = node.value<std::string>();
  if (!node.is_string() || !v) Fail(path, node, key, "must be a string");
  return *v;
}

double Number(const std::string& path, const toml::node& node, const std::string& key) {
  if (node.is_integer()) return static_cast<double>(*node.value<int64_t>());
  if (!node.is_floating_point()) Fail(path, node, key, "must be a number");
  return *node.value<double>();
}

bool Bool(const std::string& path, const toml::node& node, const std::string& key) {
  if (!node.is_boolean()) Fail(path, node, key, "must be true or false");
  return *node.value<bool>();
}

// A path in the config file is relative to the file's folder (a service's
// working directory is not the operator's).
std::string RelativeTo(const std::string& config_path, const std::string& value) {
  if (value.empty() || value.find("://") != std::string::npos) return value;
  const std::filesystem::path p(value);
  if (p.is_absolute()) return value;
  return (std::filesystem::path(config_path).parent_path() / p).lexically_normal().string();
}

}  // namespace

const std::vector<std::string>& DaqConfigKeys() {
  static const std::vector<std::string> keys = {
      "rig",    "input",     "speed", "max",         "lcm-url",        "prefix",
      "follow", "idle-timeout", "delimiter", "log", "rotate-size", "rotate-seconds", "raw-url"};
  return keys;
}

void ApplyDaqConfigFile(const std::string& path, DaqStageOptions& o,
                        const std::function<bool(const std::string& key)>& given) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw OptionError("--config: cannot open '" + path + "'");
  std::stringstream text;
  text << in.rdbuf();
  toml::table root;
  try {
    root = toml::parse(text.str(), path);
  } catch (const toml::parse_error& e) {
    std::ostringstream msg;
    msg << path << ":" << e.source().begin.line << ": " << e.description();
    throw OptionError(msg.str());
  }
  for (const auto& [key_view, node] : root) {
    const std::string key(key_view.str());
    bool known = false;
    for (const auto& k : DaqConfigKeys()) known = known || k == key;
    if (!known) {
      std::string list;
      for (const auto& k : DaqConfigKeys()) list += (list.empty() ? "" : ", ") + k;
      Fail(path, node, key, "is not an option of rocklab daq (keys: " + list + ")");
    }
    if (given && given(key)) continue;  // the command line overrides
    if (key == "rig") o.rig_path = RelativeTo(path, String(path, node, key));
    if (key == "input") o.input = RelativeTo(path, String(path, node, key));
    if (key == "log") o.log_path = RelativeTo(path, String(path, node, key));
    if (key == "lcm-url") o.lcm_url = String(path, node, key);
    if (key == "raw-url") o.raw_url = String(path, node, key);
    if (key == "prefix") o.prefix = String(path, node, key);
    if (key == "delimiter") o.delimiter = String(path, node, key);
    if (key == "max") o.max_speed = Bool(path, node, key);
    if (key == "follow") o.follow = Bool(path, node, key);
    if (key == "speed") {
      o.speed = Number(path, node, key);
      if (!(o.speed > 0)) Fail(path, node, key, "must be > 0");
    }
    if (key == "idle-timeout") {
      o.idle_timeout_s = Number(path, node, key);
      if (!(o.idle_timeout_s >= 0)) Fail(path, node, key, "must be >= 0 s");
    }
    if (key == "rotate-seconds") {
      o.rotate_seconds = Number(path, node, key);
      if (!(o.rotate_seconds >= 0)) Fail(path, node, key, "must be >= 0 s");
    }
    if (key == "rotate-size") {
      if (!node.is_integer() || *node.value<int64_t>() < 0) Fail(path, node, key, "must be a count of bytes >= 0");
      o.rotate_bytes = *node.value<int64_t>();
    }
  }
}

}  // namespace rocklab::pipeline
