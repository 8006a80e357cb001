#pragma once
// Point-in-body queries on a closed triangle mesh (CGAL AABB tree + Side_of_triangle_mesh).

#include <Eigen/Core>
#include <memory>
#include <string>

#include "demnerf/core/ply.hpp"

namespace demnerf::geometry {

/// Answers "is this point inside the body?" for a closed mesh. Construction validates the mesh
/// (requireClosedMesh) and builds the search tree once; queries are then O(log faces).
class InsideTest {
 public:
  explicit InsideTest(const core::TriangleMesh& mesh, const std::string& what = "mesh");
  ~InsideTest();
  InsideTest(InsideTest&&) noexcept;
  InsideTest& operator=(InsideTest&&) noexcept;

  /// True strictly inside; points on the surface count as outside.
  bool inside(const Eigen::Vector3d& point) const;
  /// Squared distance to the nearest point of the surface.
  double squaredDistance(const Eigen::Vector3d& point) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace demnerf::geometry
