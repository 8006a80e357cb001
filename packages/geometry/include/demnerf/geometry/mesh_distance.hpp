#pragma once
// How far apart two surfaces are: Chamfer and Hausdorff distances from area-uniform samples,
// measured point-to-triangle (exact nearest point on the other mesh, CGAL AABB tree).

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "demnerf/core/ply.hpp"

namespace demnerf::geometry {

struct MeshDistanceConfig {
  std::size_t samples = 20000;  ///< area-uniform points drawn on each mesh
  std::uint64_t seed = 1;
};

struct MeshDistance {
  double a_to_b_mean = 0.0;   ///< mean distance from points of A to surface B ("accuracy" if A is the estimate)
  double b_to_a_mean = 0.0;   ///< mean distance from points of B to surface A ("completeness")
  double chamfer = 0.0;       ///< (a_to_b_mean + b_to_a_mean) / 2, the DTU / NeuS convention
  double chamfer_sum = 0.0;   ///< a_to_b_mean + b_to_a_mean (the convention that sums both sides)
  double hausdorff = 0.0;     ///< largest sampled distance, either way
};

/// Area-uniform random points on the mesh's triangles (deterministic for the seed).
std::vector<Eigen::Vector3d> sampleSurfacePoints(const core::TriangleMesh& mesh, std::size_t count,
                                                 std::uint64_t seed);

/// Distances of the points to the nearest point of the mesh's surface (open meshes are fine).
std::vector<double> distancesToMesh(const core::TriangleMesh& mesh, const std::vector<Eigen::Vector3d>& points);

/// Symmetric distances between two surfaces. Throws core::Error when either mesh has no
/// faces of positive area or samples is 0.
MeshDistance meshDistance(const core::TriangleMesh& a, const core::TriangleMesh& b,
                          const MeshDistanceConfig& config = {});

}  // namespace demnerf::geometry
