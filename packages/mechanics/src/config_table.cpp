#include "config_table.hpp"

#include <cmath>
#include <cstdio>

namespace demnerf::mechanics::config_table {

std::string formatNumber(double value) {
  char text[64];
  std::snprintf(text, sizeof text, "%.15g", value);
  return text;
}

Field integer(std::string section, std::string key, int& field, int lo, int hi, std::string meaning) {
  return {std::move(section), std::move(key), std::move(meaning),
          [&field, lo, hi](const YAML::Node& node) -> std::string {
            const std::string range = hi == std::numeric_limits<int>::max()
                                          ? ">= " + std::to_string(lo)
                                          : "in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
            long long value = 0;
            try {
              value = node.as<long long>();
            } catch (const YAML::Exception&) {
              return "must be an integer " + range + ", got '" + YAML::Dump(node) + "'";
            }
            if (value < lo || value > hi) return "must be an integer " + range + ", got " + std::to_string(value);
            field = static_cast<int>(value);
            return "";
          },
          [&field] { return std::to_string(field); }};
}

Field number(std::string section, std::string key, double& field, double lo, bool lo_open, double hi,
             std::string meaning) {
  return {std::move(section), std::move(key), std::move(meaning),
          [&field, lo, lo_open, hi](const YAML::Node& node) -> std::string {
            std::string range = std::isinf(hi) ? (lo_open ? "> " : ">= ") + formatNumber(lo)
                                               : std::string(lo_open ? "in (" : "in [") + formatNumber(lo) + ", " +
                                                     formatNumber(hi) + "]";
            if (std::isinf(lo) && std::isinf(hi)) range = "(finite)";
            double value = 0.0;
            try {
              value = node.as<double>();
            } catch (const YAML::Exception&) {
              return "must be a number " + range + ", got '" + YAML::Dump(node) + "'";
            }
            if (!std::isfinite(value) || value < lo || (lo_open && value == lo) || value > hi)
              return "must be a number " + range + ", got " + YAML::Dump(node);
            field = value;
            return "";
          },
          [&field] { return formatNumber(field); }};
}

Field flag(std::string section, std::string key, bool& field, std::string meaning) {
  return {std::move(section), std::move(key), std::move(meaning),
          [&field](const YAML::Node& node) -> std::string {
            try {
              field = node.as<bool>();
            } catch (const YAML::Exception&) {
              return "must be true or false, got '" + YAML::Dump(node) + "'";
            }
            return "";
          },
          [&field] { return std::string(field ? "true" : "false"); }};
}

std::vector<std::pair<std::string, std::string>> words(std::initializer_list<const char*> list) {
  std::vector<std::pair<std::string, std::string>> out;
  for (const char* w : list) out.emplace_back(w, w);
  return out;
}

}  // namespace demnerf::mechanics::config_table
