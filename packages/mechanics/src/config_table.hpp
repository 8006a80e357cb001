#pragma once
// The rows of the solver config table (solver_config_yaml.cpp): one per key, each knowing how to
// read, check and write its field. Private to the mechanics package (yaml-cpp stays out of the
// public headers).

#include <yaml-cpp/yaml.h>

#include <functional>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "demnerf/mechanics/simulate.hpp"

namespace demnerf::mechanics::config_table {

// One row per key: where it lives, what it means, and how it is read (returning what is wrong with
// a value, empty when it was taken) and written. One table drives reading, writing and the key
// list, so the example file, the loader and the tests cannot disagree.
struct Field {
  std::string section;  ///< "" for a top-level key; "dem.grid" for a key of a part of a section
  std::string key;
  std::string meaning;
  std::function<std::string(const YAML::Node&)> read;
  std::function<std::string()> write;
};

constexpr double kInf = std::numeric_limits<double>::infinity();

std::string formatNumber(double value);
/// An integer in [lo, hi].
Field integer(std::string section, std::string key, int& field, int lo, int hi, std::string meaning);
/// A finite number in [lo, hi] (lo excluded when `lo_open`).
Field number(std::string section, std::string key, double& field, double lo, bool lo_open, double hi,
             std::string meaning);
Field flag(std::string section, std::string key, bool& field, std::string meaning);
/// Each word spelled as itself (for choice over a string field).
std::vector<std::pair<std::string, std::string>> words(std::initializer_list<const char*> list);

/// A string or an enum spelled as one of `names` (in the order of `values`).
template <class T>
Field choice(std::string section, std::string key, T& field, std::vector<std::pair<std::string, T>> names,
             std::string meaning) {
  std::string list;
  for (const auto& n : names) list += (list.empty() ? "" : ", ") + n.first;
  return {std::move(section), std::move(key), std::move(meaning) + " (" + list + ")",
          [&field, names, list](const YAML::Node& node) -> std::string {
            std::string value;
            try {
              value = node.as<std::string>();
            } catch (const YAML::Exception&) {
              return "must be one of " + list + ", got '" + YAML::Dump(node) + "'";
            }
            for (const auto& n : names)
              if (n.first == value) {
                field = n.second;
                return "";
              }
            return "must be one of " + list + ", got '" + value + "'";
          },
          [&field, names] {
            for (const auto& n : names)
              if (n.second == field) return n.first;
            return std::string("?");
          }};
}

/// DemConfig's rows, sections "dem" (top-level solve settings) and "dem.<part>" (network,
/// boundary, adam, output_newton, lbfgs, grid, parametric).
std::vector<Field> demFields(DemConfig& c);

/// The flat DemConfig key of earlier files ("grid_cell") as its nested "part.key" ("grid.cell");
/// empty when `flat_key` was never a DEM key.
std::string renamedDemKey(const std::string& flat_key);

}  // namespace demnerf::mechanics::config_table
