#include "demnerf/core/scenario.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include "demnerf/core/error.hpp"

namespace demnerf::core {
namespace {

std::string formatVector(const Eigen::Vector3d& v) {
  std::ostringstream text;
  text << "(" << v.x() << "," << v.y() << "," << v.z() << ")";
  return text.str();
}

// Reads YAML values and names the file and key path in every complaint.
class Reader {
 public:
  explicit Reader(std::string source) : source_(std::move(source)) {}

  [[noreturn]] void fail(const std::string& key, const std::string& problem) const {
    throw Error(source_ + ": '" + key + "' " + problem);
  }

  double number(const YAML::Node& node, const std::string& key) const {
    if (!node || !node.IsScalar()) fail(key, "must be a number");
    double value = 0;
    try {
      value = node.as<double>();
    } catch (const YAML::Exception&) {
      fail(key, "must be a number, got '" + node.Scalar() + "'");
    }
    if (!std::isfinite(value)) fail(key, "must be finite, got '" + node.Scalar() + "'");
    return value;
  }

  double number(const YAML::Node& map, const std::string& field, const std::string& key, double fallback) const {
    return map[field] ? number(map[field], key + "." + field) : fallback;
  }

  Eigen::Vector3d vector(const YAML::Node& node, const std::string& key) const {
    if (!node || !node.IsSequence() || node.size() != 3) fail(key, "must be a list of 3 numbers like [0, 0, 1]");
    return {number(node[0], key + "[0]"), number(node[1], key + "[1]"), number(node[2], key + "[2]")};
  }

  Eigen::Vector3d vector(const YAML::Node& map, const std::string& field, const std::string& key,
                         const Eigen::Vector3d& fallback) const {
    return map[field] ? vector(map[field], key + "." + field) : fallback;
  }

  std::string text(const YAML::Node& map, const std::string& field, const std::string& key,
                   const std::string& fallback) const {
    if (!map[field]) return fallback;
    if (!map[field].IsScalar()) fail(key + "." + field, "must be text");
    return map[field].as<std::string>();
  }

  void rejectUnknown(const YAML::Node& map, const std::set<std::string>& known, const std::string& key) const {
    for (const auto& entry : map) {
      const std::string name = entry.first.as<std::string>();
      if (!known.count(name)) fail(key.empty() ? name : key + "." + name, "is not a known key");
    }
  }

  Region region(const YAML::Node& node, const std::string& key) const {
    if (!node || !node.IsMap()) fail(key, "must be a map with type box|sphere|halfspace");
    rejectUnknown(node, {"type", "center", "size", "radius", "normal"}, key);
    Region region;
    const std::string type = text(node, "type", key, "");
    region.center = vector(node, "center", key, Eigen::Vector3d::Zero());
    if (type == "box") {
      region.type = Region::Type::kBox;
      region.size = vector(node["size"], key + ".size");
      if ((region.size.array() <= 0).any()) fail(key + ".size", "must be positive, got " + formatVector(region.size));
    } else if (type == "sphere") {
      region.type = Region::Type::kSphere;
      region.radius = number(node["radius"], key + ".radius");
      if (region.radius <= 0) fail(key + ".radius", "must be positive");
    } else if (type == "halfspace") {
      region.type = Region::Type::kHalfspace;
      region.normal = vector(node["normal"], key + ".normal");
      if (region.normal.norm() < 1e-12) fail(key + ".normal", "must not be zero");
      region.normal.normalize();
    } else {
      fail(key + ".type", "must be box, sphere or halfspace, got '" + type + "'");
    }
    return region;
  }

 private:
  std::string source_;
};

Material readMaterial(const Reader& reader, const YAML::Node& node) {
  if (!node || !node.IsMap()) reader.fail("material", "is missing (needs model, youngs_modulus, poisson_ratio)");
  reader.rejectUnknown(node, {"model", "youngs_modulus", "poisson_ratio", "density"}, "material");
  Material material;
  material.model = reader.text(node, "model", "material", material.model);
  material.youngs_modulus = reader.number(node["youngs_modulus"], "material.youngs_modulus");
  material.poisson_ratio = reader.number(node["poisson_ratio"], "material.poisson_ratio");
  material.density = reader.number(node, "density", "material", material.density);
  return material;
}

}  // namespace

bool Region::contains(const Eigen::Vector3d& point) const {
  switch (type) {
    case Type::kBox: return ((point - center).cwiseAbs().array() <= 0.5 * size.array()).all();
    case Type::kSphere: return (point - center).squaredNorm() <= radius * radius;
    case Type::kHalfspace: return (point - center).dot(normal) <= 0.0;
  }
  return false;
}

const char* Region::typeName(Type type) {
  switch (type) {
    case Type::kBox: return "box";
    case Type::kSphere: return "sphere";
    case Type::kHalfspace: return "halfspace";
  }
  return "?";
}

std::string Region::describe() const {
  std::ostringstream text;
  text << typeName(type) << " center " << formatVector(center);
  if (type == Type::kBox) text << " size " << formatVector(size);
  if (type == Type::kSphere) text << " radius " << radius;
  if (type == Type::kHalfspace) text << " normal " << formatVector(normal);
  return text.str();
}

double Material::mu() const { return youngs_modulus / (2.0 * (1.0 + poisson_ratio)); }
double Material::lambda() const {
  return youngs_modulus * poisson_ratio / ((1.0 + poisson_ratio) * (1.0 - 2.0 * poisson_ratio));
}
double Material::kappa() const { return youngs_modulus / (3.0 * (1.0 - 2.0 * poisson_ratio)); }

void Scenario::validate(const std::string& source) const {
  auto fail = [&](const std::string& what) { throw Error(source + ": " + what); };
  if (material.model != "neo_hookean" && material.model != "neo_hookean_decoupled") {
    fail("material.model '" + material.model + "' is unknown (use neo_hookean or neo_hookean_decoupled)");
  }
  if (!(material.youngs_modulus > 0)) fail("material.youngs_modulus must be > 0 Pa");
  if (!(material.poisson_ratio > -1.0 && material.poisson_ratio < 0.5)) {
    fail("material.poisson_ratio must lie in (-1, 0.5), got " + std::to_string(material.poisson_ratio));
  }
  if (!(material.density >= 0)) fail("material.density must be >= 0");
  if (!body_force.allFinite()) fail("body_force must be finite");
  if (fixtures.empty()) {
    fail("no fixtures: the body could move rigidly; add at least one fixture (e.g. a clamped base)");
  }
  for (const Fixture& fixture : fixtures) {
    if (!fixture.displacement.allFinite() || !fixture.region.center.allFinite()) {
      fail("fixture '" + fixture.name + "' holds NaN or Inf");
    }
  }
  for (const Load& load : loads) {
    if (!load.force.allFinite() || !load.torque.allFinite() || !load.region.center.allFinite()) {
      fail("load '" + load.name + "' holds NaN or Inf");
    }
  }
  if (load_steps < 1) fail("load_steps must be >= 1");
}

Scenario parseScenario(const std::string& yaml_text, const std::string& source) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& error) {
    throw Error(source + ": not valid YAML: " + error.what());
  }
  if (!root.IsMap()) throw Error(source + ": expected a map with material, fixtures and loads");
  const Reader reader(source);
  reader.rejectUnknown(root, {"name", "material", "body_force", "fixtures", "loads", "load_steps"}, "");
  Scenario scenario;
  scenario.name = reader.text(root, "name", "", "");
  scenario.material = readMaterial(reader, root["material"]);
  scenario.body_force = reader.vector(root, "body_force", "", Eigen::Vector3d::Zero());
  scenario.load_steps = static_cast<int>(reader.number(root, "load_steps", "", 1));
  if (root["fixtures"]) {
    if (!root["fixtures"].IsSequence()) reader.fail("fixtures", "must be a list");
    for (std::size_t i = 0; i < root["fixtures"].size(); ++i) {
      const YAML::Node node = root["fixtures"][i];
      const std::string key = "fixtures[" + std::to_string(i) + "]";
      if (!node.IsMap()) reader.fail(key, "must be a map with name, region, displacement");
      reader.rejectUnknown(node, {"name", "region", "displacement", "constrained"}, key);
      Fixture fixture;
      fixture.name = reader.text(node, "name", key, key);
      fixture.region = reader.region(node["region"], key + ".region");
      fixture.displacement = reader.vector(node, "displacement", key, Eigen::Vector3d::Zero());
      if (node["constrained"]) {
        const YAML::Node mask = node["constrained"];
        if (!mask.IsSequence() || mask.size() != 3) reader.fail(key + ".constrained", "must be 3 booleans like [true, true, false]");
        for (int axis = 0; axis < 3; ++axis) {
          try {
            fixture.constrained[axis] = mask[axis].as<bool>() ? 1 : 0;
          } catch (const YAML::Exception&) {
            reader.fail(key + ".constrained", "must be 3 booleans like [true, true, false]");
          }
        }
      }
      scenario.fixtures.push_back(fixture);
    }
  }
  if (root["loads"]) {
    if (!root["loads"].IsSequence()) reader.fail("loads", "must be a list");
    for (std::size_t i = 0; i < root["loads"].size(); ++i) {
      const YAML::Node node = root["loads"][i];
      const std::string key = "loads[" + std::to_string(i) + "]";
      if (!node.IsMap()) reader.fail(key, "must be a map with name, region, force, torque");
      reader.rejectUnknown(node, {"name", "region", "force", "torque"}, key);
      Load load;
      load.name = reader.text(node, "name", key, key);
      load.region = reader.region(node["region"], key + ".region");
      load.force = reader.vector(node, "force", key, Eigen::Vector3d::Zero());
      load.torque = reader.vector(node, "torque", key, Eigen::Vector3d::Zero());
      scenario.loads.push_back(load);
    }
  }
  scenario.validate(source);
  return scenario;
}

Scenario loadScenario(const std::string& path) {
  std::ifstream stream(path);
  if (!stream) throw Error("cannot open scenario file '" + path + "'");
  std::stringstream text;
  text << stream.rdbuf();
  return parseScenario(text.str(), path);
}

namespace {

void emitVector(YAML::Emitter& out, const Eigen::Vector3d& v) {
  out << YAML::Flow << YAML::BeginSeq << v.x() << v.y() << v.z() << YAML::EndSeq;
}

void emitRegion(YAML::Emitter& out, const Region& region) {
  out << YAML::Key << "region" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "type" << YAML::Value << Region::typeName(region.type);
  out << YAML::Key << "center" << YAML::Value;
  emitVector(out, region.center);
  switch (region.type) {
    case Region::Type::kBox:
      out << YAML::Key << "size" << YAML::Value;
      emitVector(out, region.size);
      break;
    case Region::Type::kSphere:
      out << YAML::Key << "radius" << YAML::Value << region.radius;
      break;
    case Region::Type::kHalfspace:
      out << YAML::Key << "normal" << YAML::Value;
      emitVector(out, region.normal);
      break;
  }
  out << YAML::EndMap;
}

}  // namespace

std::string toYaml(const Scenario& scenario) {
  YAML::Emitter out;
  out.SetDoublePrecision(17);
  out << YAML::BeginMap;
  out << YAML::Key << "name" << YAML::Value << scenario.name;
  out << YAML::Key << "material" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "model" << YAML::Value << scenario.material.model;
  out << YAML::Key << "youngs_modulus" << YAML::Value << scenario.material.youngs_modulus;
  out << YAML::Key << "poisson_ratio" << YAML::Value << scenario.material.poisson_ratio;
  out << YAML::Key << "density" << YAML::Value << scenario.material.density;
  out << YAML::EndMap;
  out << YAML::Key << "body_force" << YAML::Value;
  emitVector(out, scenario.body_force);
  out << YAML::Key << "load_steps" << YAML::Value << scenario.load_steps;
  out << YAML::Key << "fixtures" << YAML::Value << YAML::BeginSeq;
  for (const Fixture& f : scenario.fixtures) {
    out << YAML::BeginMap << YAML::Key << "name" << YAML::Value << f.name;
    emitRegion(out, f.region);
    out << YAML::Key << "displacement" << YAML::Value;
    emitVector(out, f.displacement);
    out << YAML::Key << "constrained" << YAML::Value << YAML::Flow << YAML::BeginSeq << (f.constrained.x() != 0)
        << (f.constrained.y() != 0) << (f.constrained.z() != 0) << YAML::EndSeq << YAML::EndMap;
  }
  out << YAML::EndSeq;
  out << YAML::Key << "loads" << YAML::Value << YAML::BeginSeq;
  for (const Load& l : scenario.loads) {
    out << YAML::BeginMap << YAML::Key << "name" << YAML::Value << l.name;
    emitRegion(out, l.region);
    out << YAML::Key << "force" << YAML::Value;
    emitVector(out, l.force);
    out << YAML::Key << "torque" << YAML::Value;
    emitVector(out, l.torque);
    out << YAML::EndMap;
  }
  out << YAML::EndSeq << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

}  // namespace demnerf::core
