#pragma once
// Small helpers for reading and checking ~ parameters, so each node's Config::fromParameters
// stays a flat list of keys with their checks. `Node` is a ros::NodeHandle, or a ParameterMap
// (parameter_map.hpp) where a config is read without a master (tests).

#include <ros/ros.h>

#include <cmath>
#include <string>
#include <vector>

#include "demnerf/core/error.hpp"

namespace dem_nerf {

/// Reads ~name into value when set; throws core::Error when it is not finite or below `minimum`.
template <class Node>
void readNumber(const Node& node, const std::string& name, double& value, double minimum) {
  node.param(name, value, value);
  if (!std::isfinite(value) || value < minimum) {
    throw demnerf::core::Error("parameter ~" + name + " must be a number >= " + std::to_string(minimum) +
                               ", got " + std::to_string(value));
  }
}

template <class Node>
void readCount(const Node& node, const std::string& name, int& value, int minimum) {
  node.param(name, value, value);
  if (value < minimum) {
    throw demnerf::core::Error("parameter ~" + name + " must be an integer >= " + std::to_string(minimum) +
                               ", got " + std::to_string(value));
  }
}

/// Reads ~name as a list of exactly `size` finite numbers when set (empty when unset).
template <class Node>
std::vector<double> readList(const Node& node, const std::string& name, std::size_t size) {
  std::vector<double> values;
  if (!node.getParam(name, values)) return {};
  if (values.size() != size) {
    throw demnerf::core::Error("parameter ~" + name + " must hold " + std::to_string(size) + " numbers");
  }
  for (double v : values) {
    if (!std::isfinite(v)) throw demnerf::core::Error("parameter ~" + name + " holds NaN or Inf");
  }
  return values;
}

}  // namespace dem_nerf
