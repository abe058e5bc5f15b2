#include "params.hpp"

#include <cstdio>

#include "pl/common/error.hpp"

namespace pl::ros1 {

// A parameter as text for set_config_field (numbers, booleans and strings, as YAML gives them).
std::optional<std::string> param_text(const ::ros::NodeHandle& nh, const std::string& name) {
  XmlRpc::XmlRpcValue v;
  if (!nh.getParam(name, v)) return std::nullopt;
  switch (v.getType()) {
    case XmlRpc::XmlRpcValue::TypeBoolean: return static_cast<bool>(v) ? "true" : "false";
    case XmlRpc::XmlRpcValue::TypeInt: return std::to_string(static_cast<int>(v));
    case XmlRpc::XmlRpcValue::TypeDouble: {
      char buf[64];
      std::snprintf(buf, sizeof buf, "%.17g", static_cast<double>(v));
      return std::string(buf);
    }
    case XmlRpc::XmlRpcValue::TypeString: return static_cast<std::string>(v);
    default: throw Error("parameter " + nh.resolveName(name) + ": expected a number, a boolean or a string");
  }
}

std::vector<double> param_list(const ::ros::NodeHandle& nh, const std::string& name) {
  XmlRpc::XmlRpcValue v;
  std::vector<double> out;
  if (!nh.getParam(name, v)) return out;
  if (v.getType() != XmlRpc::XmlRpcValue::TypeArray) throw Error("parameter " + nh.resolveName(name) + ": expected a list of numbers");
  for (int i = 0; i < v.size(); ++i) {
    if (v[i].getType() == XmlRpc::XmlRpcValue::TypeDouble) out.push_back(static_cast<double>(v[i]));
    else if (v[i].getType() == XmlRpc::XmlRpcValue::TypeInt) out.push_back(static_cast<int>(v[i]));
    else throw Error("parameter " + nh.resolveName(name) + ": element " + std::to_string(i) + " is not a number");
  }
  return out;
}

}  // namespace pl::ros1
