#pragma once
// Generalized winding number: an inside test that needs no search structure, used to check
// the CGAL-based one (and usable on meshes with small holes).

#include <Eigen/Core>

#include "demnerf/core/ply.hpp"

namespace demnerf::geometry {

/// Sum of the solid angles the faces subtend at `point`, over 4 pi (Van Oosterom-Strackee).
/// About 1 inside an outward-oriented closed mesh, 0 outside. O(faces) per query.
double windingNumber(const core::TriangleMesh& mesh, const Eigen::Vector3d& point);

}  // namespace demnerf::geometry
