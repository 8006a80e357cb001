#include "ros_params/parameters_yaml.hpp"

#include <yaml-cpp/yaml.h>

namespace dem_nerf {
namespace {

YAML::Node toYaml(XmlRpc::XmlRpcValue value) {  // a copy: XmlRpcValue's conversions are non-const
  switch (value.getType()) {
    case XmlRpc::XmlRpcValue::TypeBoolean:
      return YAML::Node(static_cast<bool>(value));
    case XmlRpc::XmlRpcValue::TypeInt:
      return YAML::Node(static_cast<int>(value));
    case XmlRpc::XmlRpcValue::TypeDouble:
      return YAML::Node(static_cast<double>(value));  // yaml-cpp writes max_digits10 digits
    case XmlRpc::XmlRpcValue::TypeString:
      return YAML::Node(static_cast<std::string>(value));
    case XmlRpc::XmlRpcValue::TypeArray: {
      YAML::Node list(YAML::NodeType::Sequence);
      for (int i = 0; i < value.size(); ++i) list.push_back(toYaml(value[i]));
      return list;
    }
    case XmlRpc::XmlRpcValue::TypeStruct: {
      YAML::Node map(YAML::NodeType::Map);
      for (auto& [key, item] : value) map[key] = toYaml(item);
      return map;
    }
    default:  // dates, base64, invalid: no setting takes them; the loaders say what they expect
      return YAML::Node();
  }
}

}  // namespace

std::string yamlText(const XmlRpc::XmlRpcValue& value) {
  YAML::Emitter out;
  out << toYaml(value);
  return out.c_str();
}

}  // namespace dem_nerf
