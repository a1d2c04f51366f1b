#include "model/variant.h"

#include <cctype>
#include <cmath>
#include <fstream>
#include <stdexcept>
#include <string_view>

#include <nlohmann/json.hpp>

#include "common/text.h"
#include "model/model_registry.h"

namespace rocklab::model {
namespace {

double ParseNumber(const std::string& text, const std::string& what) {
  double v = 0;
  if (!common::ParseDouble(text, v) || !std::isfinite(v)) {
    throw std::invalid_argument(what + ": '" + text + "' is not a number");
  }
  return v;
}

}  // namespace

BlockParams ReadParamsJson(const std::string& path, double* l) {
  std::ifstream in(path);
  if (!in) throw std::invalid_argument("cannot read parameter file '" + path + "'");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw std::invalid_argument(path + ": not JSON: " + e.what());
  }
  auto get = [&](const char* key) {
    if (!j.is_object() || !j.contains(key) || !j.at(key).is_number()) {
      throw std::invalid_argument(path + ": key '" + key + "' missing or not a number");
    }
    return j.at(key).get<double>();
  };
  BlockParams p{get("alpha"), get("p"), get("mu")};
  if (l && j.is_object() && j.contains("l") && j.at("l").is_number()) *l = j.at("l").get<double>();
  try {
    p.Validate();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(path + ": " + e.what());
  }
  return p;
}

VariantSpec ParseVariant(const std::string& text, const std::optional<BlockParams>& theoretical) {
  const std::string where = "variant '" + text + "'";
  const std::size_t c1 = text.find(':');
  const std::size_t c2 = c1 == std::string::npos ? c1 : text.find(':', c1 + 1);
  if (c2 == std::string::npos) {
    throw std::invalid_argument(where + ": expected NAME:MODEL:PARAMS");
  }
  VariantSpec v;
  v.name = text.substr(0, c1);
  if (v.name.empty()) throw std::invalid_argument(where + ": empty NAME");
  for (char ch : v.name) {
    if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '_') {
      throw std::invalid_argument(where + ": NAME may hold only letters, digits and _");
    }
  }
  try {
    v.kind = ParseModelKind(text.substr(c1 + 1, c2 - c1 - 1));
  } catch (const std::invalid_argument&) {
    throw std::invalid_argument(where + ": MODEL must be " + ModelNames(" or "));
  }
  const std::string params = text.substr(c2 + 1);
  constexpr std::string_view kAssemblySuffix = ".toml";
  if (params.size() > kAssemblySuffix.size() &&
      params.compare(params.size() - kAssemblySuffix.size(), kAssemblySuffix.size(), kAssemblySuffix) == 0) {
    v.assembly_path = params;  // read, with its block or stack, by the caller (pipeline::BuildVariants)
    v.params_source = params;
    return v;
  }
  if (params == "theoretical") {
    if (!theoretical) {
      throw std::invalid_argument(where + ": 'theoretical' needs the block geometry in the rig file");
    }
    v.params = *theoretical;
    v.params_source = "theoretical";
  } else if (params.find('=') != std::string::npos) {
    bool has_alpha = false, has_p = false, has_mu = false;
    std::size_t start = 0;
    while (start <= params.size()) {
      const std::size_t comma = std::min(params.find(',', start), params.size());
      const std::string item = params.substr(start, comma - start);
      const std::size_t eq = item.find('=');
      if (eq == std::string::npos) throw std::invalid_argument(where + ": '" + item + "' is not KEY=VALUE");
      const std::string key = item.substr(0, eq);
      const double value = ParseNumber(item.substr(eq + 1), where + ": " + key);
      if (key == "alpha") {
        v.params.alpha = value;
        has_alpha = true;
      } else if (key == "p") {
        v.params.p = value;
        has_p = true;
      } else if (key == "mu") {
        v.params.mu = value;
        has_mu = true;
      } else if (key == "l") {
        v.options.l = value;
      } else if (key == "handoff") {  // opt-in l -> 0 hand-off of the complex model
        v.options.complex_resolved_energy = value;
      } else {
        throw std::invalid_argument(where + ": unknown key '" + key + "' (expected alpha, p, mu, l, handoff)");
      }
      start = comma + 1;
    }
    if (!has_alpha || !has_p || !has_mu) {
      throw std::invalid_argument(where + ": needs alpha, p and mu");
    }
    v.params_source = "command line";
  } else {
    v.params = ReadParamsJson(params, &v.options.l);
    v.params_source = params;
  }
  try {
    v.params.Validate();
    v.options.Validate();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(where + ": " + e.what());
  }
  return v;
}

}  // namespace rocklab::model
