#pragma once
// The closed surface a sampled particle cloud describes, as a triangle mesh: the zero level of
// ParticleInsideTest's signed distance (the tangent planes of the surface particles) on a grid,
// by marching tetrahedra. It lets the FEM mesh a cloud with CGAL as it meshes a given surface,
// whichever sampler made the particles, instead of voxel blocks that the particles fill.

#include "demnerf/core/ply.hpp"

namespace demnerf::mechanics {

class ParticleInsideTest;

/// Whether the cloud's surface particles lie on the surface, as a sampler leaves them (area > 0, a
/// normal, no volume), so that they place it. False without surface particles, or when one carries
/// no normal or a cell of volume (a lattice whose every particle is a cell, as the node tests'
/// bars: its surface lies half a cell beyond those particles).
bool particlesDescribeSurface(const core::ParticleCloud& cloud);

/// The surface of `cloud` sampled every `step` metres (a face lies where the signed distance
/// crosses zero: exact for planar faces; edges put back where the faces' planes meet by
/// sharpenEdges(), or with `sharpen` false chamfered over about a step). The cloud's surface
/// particles must lie on its surface (particlesDescribeSurface); throws core::Error otherwise, for
/// a step that is not a positive length or gives more than 2e7 samples, or when no surface results.
core::TriangleMesh surfaceOfParticles(const core::ParticleCloud& cloud, double step, bool sharpen = true);

/// The same with the cloud's inside test made by the caller, who also asks it other things (the
/// FEM: how rough the surface is). `inside` must be `cloud`'s, with setBlendRoughFaces(false) (the
/// nearest plane, as the overload above sets).
core::TriangleMesh surfaceOfParticles(const core::ParticleCloud& cloud, const ParticleInsideTest& inside, double step,
                                      bool sharpen = true);

}  // namespace demnerf::mechanics
