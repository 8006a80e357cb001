#pragma once
// The planes that bound the volumes a scenario's fixtures hold, for the CGAL mesher to conform to
// (CgalMeshConfig::cut_planes): with nodes on them the FEM holds the body up to the boundary of
// the held volume instead of up to the last layer of nodes short of it (a cuboid clamped over
// x <= 15 mm was 3.5 % soft in energy; docs/dem_feature_grid.md, "Held volumes cut cells too").

#include <vector>

#include "demnerf/core/ply.hpp"
#include "demnerf/core/scenario.hpp"
#include "demnerf/mechanics/cgal_tet_mesh.hpp"

namespace demnerf::mechanics {

/// The faces of the axis-aligned box `box` that cross the body bounded by `surface` from side to
/// side: the face's plane cuts the surface and the whole cross-section lies within the face (up to
/// `tolerance`). A slab across a bar gives its two faces; a face that ends inside the body (its
/// rim would be an edge of the mesh inside the body), or that misses it, gives none.
std::vector<CgalMeshConfig::Plane> boxFacesAcrossBody(const core::TriangleMesh& surface, const core::Region& box,
                                                      double tolerance);

/// The planes bounding the fixtures' held volumes: every halfspace fixture's plane, and the
/// faces across the body (boxFacesAcrossBody) of each box fixture that grips no face of the
/// surface (a box that grips one holds only that face: held_face.hpp). Sphere fixtures add none.
std::vector<CgalMeshConfig::Plane> heldVolumePlanes(const core::Scenario& scenario,
                                                    const core::TriangleMesh& surface);

}  // namespace demnerf::mechanics
