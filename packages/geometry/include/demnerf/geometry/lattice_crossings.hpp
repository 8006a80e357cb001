#pragma once
// Where lines of a regular lattice cross a closed mesh, and which lattice nodes lie inside.
// A scanline method: exact-once crossing counts on watertight meshes, even when a line runs
// through an edge or vertex, by a symbolic perturbation of the line.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "demnerf/core/ply.hpp"

namespace demnerf::geometry {

/// Nodes origin + (i, j, k) * spacing for 0 <= i < dims.x() etc.
struct Lattice {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d spacing = Eigen::Vector3d::Ones();
  Eigen::Vector3i dims = Eigen::Vector3i::Zero();

  std::size_t size() const {
    return static_cast<std::size_t>(dims.x()) * dims.y() * dims.z();
  }
  std::size_t index(int i, int j, int k) const {
    return (static_cast<std::size_t>(k) * dims.y() + j) * dims.x() + i;
  }
  Eigen::Vector3d node(int i, int j, int k) const {
    return origin + Eigen::Vector3d(i, j, k).cwiseProduct(spacing);
  }
};

/// One place where a lattice line parallel to `axis` crosses a face.
struct LineCrossing {
  double position;  ///< coordinate along the axis
  int sign;         ///< +1 where the outward normal points along +axis (the line leaves the body)
  int face;
};

/// Crossings of every lattice line parallel to `axis` (0 x, 1 y, 2 z), unsorted. Lines are
/// indexed by the two other lattice indices: line (a, b) with a along axis+1 and b along
/// axis+2 (cyclic) is entry b * dims[axis+1] + a. The mesh must use shared vertex indices.
std::vector<std::vector<LineCrossing>> latticeLineCrossings(const core::TriangleMesh& mesh,
                                                            const Lattice& lattice, int axis);

/// 1 for lattice nodes inside the closed, outward-oriented mesh, 0 outside (winding number of
/// a ray along +x). Nodes exactly on the surface may go either way.
std::vector<std::uint8_t> classifyLattice(const core::TriangleMesh& mesh, const Lattice& lattice);

}  // namespace demnerf::geometry
