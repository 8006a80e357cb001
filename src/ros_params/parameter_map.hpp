#pragma once
// A node's ~ parameters held in memory, read with ros::NodeHandle's hasParam / getParam / param
// calls and ROS's conversions (an int is accepted where a double is asked for). Lets a node's
// Config::fromParameters run without a master: its defaults and overrides become plain gtests.

#include <xmlrpcpp/XmlRpcValue.h>

#include <initializer_list>
#include <map>
#include <string>
#include <utility>
#include <vector>

namespace dem_nerf {

class ParameterMap {
 public:
  ParameterMap() = default;
  ParameterMap(std::initializer_list<std::pair<const std::string, XmlRpc::XmlRpcValue>> values) : values_(values) {}

  bool hasParam(const std::string& name) const { return values_.count(name) > 0; }

  bool getParam(const std::string& name, std::string& value) const {
    return get(name, [&](XmlRpc::XmlRpcValue& v) {
      if (v.getType() != XmlRpc::XmlRpcValue::TypeString) return false;
      value = static_cast<std::string>(v);
      return true;
    });
  }
  bool getParam(const std::string& name, double& value) const {
    return get(name, [&](XmlRpc::XmlRpcValue& v) { return toDouble(v, value); });
  }
  bool getParam(const std::string& name, int& value) const {
    return get(name, [&](XmlRpc::XmlRpcValue& v) {
      if (v.getType() != XmlRpc::XmlRpcValue::TypeInt) return false;
      value = static_cast<int>(v);
      return true;
    });
  }
  bool getParam(const std::string& name, bool& value) const {
    return get(name, [&](XmlRpc::XmlRpcValue& v) {
      if (v.getType() != XmlRpc::XmlRpcValue::TypeBoolean) return false;
      value = static_cast<bool>(v);
      return true;
    });
  }
  bool getParam(const std::string& name, std::vector<double>& value) const {
    return get(name, [&](XmlRpc::XmlRpcValue& v) {
      if (v.getType() != XmlRpc::XmlRpcValue::TypeArray) return false;
      std::vector<double> out(static_cast<std::size_t>(v.size()));
      for (int i = 0; i < v.size(); ++i)
        if (!toDouble(v[i], out[static_cast<std::size_t>(i)])) return false;
      value = std::move(out);
      return true;
    });
  }

  bool getParam(const std::string& name, std::vector<std::string>& value) const {
    return get(name, [&](XmlRpc::XmlRpcValue& v) {
      if (v.getType() != XmlRpc::XmlRpcValue::TypeArray) return false;
      std::vector<std::string> out;
      for (int i = 0; i < v.size(); ++i) {
        if (v[i].getType() != XmlRpc::XmlRpcValue::TypeString) return false;
        out.push_back(static_cast<std::string>(v[i]));
      }
      value = std::move(out);
      return true;
    });
  }
  /// The value as stored (a namespace is a struct value here, as the parameter server gives it).
  bool getParam(const std::string& name, XmlRpc::XmlRpcValue& value) const {
    const auto it = values_.find(name);
    if (it == values_.end()) return false;
    value = it->second;
    return true;
  }

  /// As ros::NodeHandle::param: the parameter when set (and of a fitting type), else `fallback`.
  template <class T>
  bool param(const std::string& name, T& value, const T& fallback) const {
    if (getParam(name, value)) return true;
    value = fallback;
    return false;
  }

 private:
  template <class Read>
  bool get(const std::string& name, Read read) const {
    const auto it = values_.find(name);
    if (it == values_.end()) return false;
    XmlRpc::XmlRpcValue copy = it->second;  // XmlRpcValue's conversions are non-const
    return read(copy);
  }
  static bool toDouble(XmlRpc::XmlRpcValue& v, double& value) {
    if (v.getType() == XmlRpc::XmlRpcValue::TypeDouble) value = static_cast<double>(v);
    else if (v.getType() == XmlRpc::XmlRpcValue::TypeInt) value = static_cast<int>(v);
    else return false;
    return true;
  }

  std::map<std::string, XmlRpc::XmlRpcValue> values_;
};

}  // namespace dem_nerf
