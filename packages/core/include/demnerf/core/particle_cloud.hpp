#pragma once
// The body and answer types every stage passes on: the particle cloud (geometry -> mechanics), a
// solver's result field (mechanics -> render, nodes) and the triangle mesh (NeRF -> geometry).
// Their files are read and written by ply.hpp.

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace demnerf::core {

/// Particles that discretise a body: interior ones have area 0, surface ones carry a unit
/// outward normal and an area weight. Fields: x y z volume nx ny nz area red green blue.
struct ParticleCloud {
  std::vector<Eigen::Vector3d> positions;
  std::vector<double> volumes;
  std::vector<Eigen::Vector3d> normals;
  std::vector<double> areas;
  std::vector<std::array<std::uint8_t, 3>> colors;

  std::size_t size() const { return positions.size(); }
  void resize(std::size_t n);
  /// Appends one grey particle: interior ones pass a zero normal and area 0, surface ones volume 0.
  void append(const Eigen::Vector3d& position, double volume, const Eigen::Vector3d& normal, double area);
  bool isSurface(std::size_t i) const { return areas[i] > 0.0; }
  /// Throws core::Error when field lengths differ or a value is not finite.
  void validate() const;
};

/// A solver's answer: rest positions, displacement and von Mises stress per particle, in the
/// order of the particle cloud it was computed on. Fields: x y z ux uy uz von_mises.
struct ResultField {
  std::vector<Eigen::Vector3d> positions;
  std::vector<Eigen::Vector3d> displacements;
  std::vector<double> von_mises;

  std::size_t size() const { return positions.size(); }
  void resize(std::size_t n);
  void validate() const;
};

/// Triangle surface mesh with counter-clockwise (outward) faces.
struct TriangleMesh {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<std::array<int, 3>> faces;
};

}  // namespace demnerf::core
