#pragma once
// Reading one flat YAML mapping of settings with messages that name the source and the key: the
// small loaders of src/pipeline (surface, sampler) share it.

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <functional>
#include <map>
#include <string>

#include "demnerf/core/error.hpp"

namespace dem_nerf {

/// The mapping in `yaml_text`, each key handed to its reader; readers return "" or what is wrong
/// with the value ("must be a number > 0, got -1"). Unknown keys, invalid YAML and non-mappings
/// are core::Errors naming `source`.
inline void readYamlKeys(const std::string& yaml_text, const std::string& source,
                         const std::map<std::string, std::function<std::string(const YAML::Node&)>>& readers) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw demnerf::core::Error(source + ": not valid YAML: " + e.what());
  }
  if (!root || root.IsNull()) return;
  if (!root.IsMap()) throw demnerf::core::Error(source + ": expected a mapping of keys to values");
  for (const auto& item : root) {
    const std::string key = item.first.as<std::string>();
    const auto reader = readers.find(key);
    if (reader == readers.end()) {
      std::string known;
      for (const auto& [name, read] : readers) known += (known.empty() ? "" : ", ") + name;
      throw demnerf::core::Error(source + ": unknown key '" + key + "' (known: " + known + ")");
    }
    std::string problem;
    try {
      problem = reader->second(item.second);
    } catch (const YAML::Exception&) {
      problem = "has a value of the wrong type: '" + YAML::Dump(item.second) + "'";
    }
    if (!problem.empty()) throw demnerf::core::Error(source + ": '" + key + "' " + problem);
  }
}

/// A reader for a number >= minimum (or > minimum when `strict`).
inline std::function<std::string(const YAML::Node&)> numberAtLeast(double* value, double minimum, bool strict = false) {
  return [=](const YAML::Node& node) -> std::string {
    const double v = node.as<double>();
    if (!std::isfinite(v) || v < minimum || (strict && v == minimum))
      return std::string("must be a number ") + (strict ? "> " : ">= ") + std::to_string(minimum) + ", got " + YAML::Dump(node);
    *value = v;
    return "";
  };
}

/// A reader for an integer in [minimum, maximum].
template <class Int>
std::function<std::string(const YAML::Node&)> integerIn(Int* value, long long minimum, long long maximum) {
  return [=](const YAML::Node& node) -> std::string {
    const long long v = node.as<long long>();
    if (v < minimum || v > maximum)
      return "must be an integer in [" + std::to_string(minimum) + ", " + std::to_string(maximum) + "], got " + YAML::Dump(node);
    *value = static_cast<Int>(v);
    return "";
  };
}

}  // namespace dem_nerf
