#pragma once
// Scenario files: material, body force, fixtures and loads of a quasi-static simulation.

#include <Eigen/Core>
#include <string>
#include <vector>

namespace demnerf::core {

/// A region of space that selects particles: an axis-aligned box, a sphere or a halfspace.
struct Region {
  enum class Type { kBox, kSphere, kHalfspace };
  Type type = Type::kBox;
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  Eigen::Vector3d size = Eigen::Vector3d::Zero();      ///< box edge lengths
  double radius = 0.0;                                 ///< sphere
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();   ///< halfspace: selects (p - center).normal <= 0

  bool contains(const Eigen::Vector3d& point) const;
  std::string describe() const;  ///< "box center (0,0,0) size (0.1,0.1,0.01)", for messages
  static const char* typeName(Type type);
};

struct Material {
  std::string model = "neo_hookean";  ///< neo_hookean | neo_hookean_decoupled
  double youngs_modulus = 1e6;        ///< Pa
  double poisson_ratio = 0.3;
  double density = 1000.0;            ///< kg/m^3

  double mu() const;      ///< shear modulus
  double lambda() const;  ///< first Lame parameter
  double kappa() const;   ///< bulk modulus
};

struct Fixture {
  std::string name;
  Region region;
  Eigen::Vector3d displacement = Eigen::Vector3d::Zero();  ///< prescribed, m
  /// Which components are prescribed (a roller fixes only some); all three by default.
  Eigen::Vector3i constrained = Eigen::Vector3i::Ones();
};

/// A resultant force and torque (about the patch centroid) spread as traction over the
/// surface particles inside the region.
struct Load {
  std::string name;
  Region region;
  Eigen::Vector3d force = Eigen::Vector3d::Zero();   ///< N
  Eigen::Vector3d torque = Eigen::Vector3d::Zero();  ///< N m
};

struct Scenario {
  std::string name;
  Material material;
  Eigen::Vector3d body_force = Eigen::Vector3d::Zero();  ///< N/m^3
  std::vector<Fixture> fixtures;
  std::vector<Load> loads;
  int load_steps = 1;  ///< the load is applied in this many equal increments

  /// Throws core::Error naming the problem (unknown model, nu outside (-1, 0.5), E <= 0,
  /// non-finite values, no fixtures). `source` prefixes the message (a file name).
  void validate(const std::string& source = "scenario") const;
};

/// Loads and validates a scenario YAML file; errors name the file, the key and the value.
Scenario loadScenario(const std::string& path);
/// Parses a scenario from YAML text (`source` names it in errors).
Scenario parseScenario(const std::string& yaml_text, const std::string& source = "scenario");
/// The scenario as YAML that parseScenario reads back to the same values (full double precision):
/// how saved solver models and nodes record the exact problem they solved.
std::string toYaml(const Scenario& scenario);

}  // namespace demnerf::core
