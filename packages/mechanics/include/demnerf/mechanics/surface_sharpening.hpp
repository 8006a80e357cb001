#pragma once
// Sharp edges back on a surface extracted from a sampled signed distance. Marching tetrahedra put
// each vertex where the distance crosses zero along a tetrahedron's edge, which is exact on a
// planar face, but a triangle whose corners lie on two different faces cuts straight across the
// edge between them: the body's edges come out chamfered over about a sample step, and a pulled
// block meshed from its particles was 2 % softer than the block. The tangent planes the distance
// comes from say where the edge is, as dual contouring's Hermite data do.

#include "demnerf/core/particle_cloud.hpp"
#include "demnerf/mechanics/particle_inside_test.hpp"

namespace demnerf::mechanics {

/// Sharpens `surface`, extracted from `inside`'s signed distance sampled every `step` metres:
/// - a vertex off the surface between two faces' planes moves to the nearest point on all of them
///   (an edge's line, a corner), when that is within a step;
/// - a triangle edge whose ends lie on planes meeting at more than 60 degrees (ParticleInsideTest's
///   edge rule) is split at the point of the planes' common line nearest its middle, within a step,
///   and its triangles with it, so the surface runs along the body's edge.
/// The surface stays closed and consistently oriented. Faces meeting at less than 60 degrees, as a
/// NeRF extraction's bumps do, are left as they are.
void sharpenEdges(core::TriangleMesh& surface, const ParticleInsideTest& inside, double step);

}  // namespace demnerf::mechanics
