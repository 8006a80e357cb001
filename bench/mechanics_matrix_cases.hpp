#pragma once
// The solver matrix's scenarios: each a YAML of config/scenarios/, the closed surface it is solved
// on, the body's smallest dimension (the particle spacings are fractions of it) and the checks
// that say whether the reference FEM answers the scenario's question (Beam3D's published tip, a
// cantilever bent by >= 20 % of its length, a 30 % compression).

#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

#include "demnerf/core/ply.hpp"

namespace demnerf::bench {

/// A point where the reference FEM is read for a sanity check.
struct Probe {
  std::string name;
  Eigen::Vector3d point;
};

/// Text and verdict of a sanity check on the reference FEM's displacements at the probes.
struct Sanity {
  std::string text;
  bool ok = true;
};

struct MatrixCase {
  std::string name;        ///< also config/scenarios/<name>.yaml
  std::string nerf_scene;  ///< `demnerf synth --scene` name when a NeRF source exists, else empty
  double smallest = 0.0;   ///< the body's smallest dimension (m)
  std::function<core::TriangleMesh()> surface;  ///< the exact closed surface
  std::vector<Probe> probes;
  std::function<Sanity(const std::vector<Eigen::Vector3d>& u_at_probes)> check;
};

/// The seven scenarios of issue 13, in the matrix's row order.
std::vector<MatrixCase> matrixCases();

}  // namespace demnerf::bench
