#pragma once
// A node's parameter namespaces as YAML text, so that each algorithm's parameters are read by the
// library's own YAML loader (the one `--config FILE` uses): the same keys, checks, defaults and
// messages on the command line and on the parameter server. ~dem/grid/cell is `dem: {grid: {cell:}}`.

#include <xmlrpcpp/XmlRpcValue.h>

#include <string>
#include <vector>

#include "demnerf/core/error.hpp"

namespace dem_nerf {

/// `value` (a struct, array or scalar from the parameter server) as YAML text.
std::string yamlText(const XmlRpc::XmlRpcValue& value);

/// A YAML mapping of each of `names` that is set under `node` to its value (a namespace becomes a
/// mapping); "" when none is set. `Node` is a ros::NodeHandle or a ParameterMap.
template <class Node>
std::string parametersAsYaml(const Node& node, const std::vector<std::string>& names) {
  XmlRpc::XmlRpcValue root;
  bool any = false;
  for (const std::string& name : names) {
    if (!node.hasParam(name)) continue;
    XmlRpc::XmlRpcValue value;
    if (!node.getParam(name, value)) continue;
    root[name] = value;
    any = true;
  }
  return any ? yamlText(root) : std::string();
}

/// `parametersAsYaml(node, {name})`'s value alone: the keys under ~name as a YAML mapping ("" when
/// ~name is not set). Throws core::Error when ~name is set to a single value, not a namespace.
template <class Node>
std::string namespaceAsYaml(const Node& node, const std::string& name) {
  if (!node.hasParam(name)) return "";
  XmlRpc::XmlRpcValue value;
  if (!node.getParam(name, value) || value.getType() != XmlRpc::XmlRpcValue::TypeStruct) {
    throw demnerf::core::Error("parameter ~" + name + " must be a namespace of keys (~" + name +
                                "/<key>: value, or <rosparam param=\"" + name + "\">{key: value}</rosparam>)");
  }
  return yamlText(value);
}

}  // namespace dem_nerf
