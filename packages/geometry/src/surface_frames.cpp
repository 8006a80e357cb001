// The normals surface particles carry, and which of them stand on walls the cloud cannot resolve
// (issue 13: the NeRF-extracted cuboid, docs/mechanics_matrix_nerf_cuboid.md).
//
// The default DEM's body is what ParticleInsideTest calls inside, built from the surface
// particles' tangent planes. A NeRF extraction's surface has two features that plane test
// mistakes for boundary:
// - thin cracks and pockets reaching into the body (the NeRF never sees the interior: 3 % of the
//   extracted cuboid's area lies more than 10 mm inside the box). A particle on a crack's wall
//   carves a spacing-wide slab out of the solid around it (the cuboid's clouds lost 8-20 % of
//   their volume, most of it there). A particle whose half-ball of one spacing in front is mostly
//   solid bounds a gap the cloud cannot resolve: it is dropped, so the gap is filled as solid (a
//   gap that thin holds well under a spacing's worth of volume). The whole half-ball, not a ray
//   along the normal: a thin cavity's rim faces along the cavity, and a rim particle left alone
//   would carve the solid on both sides of it.
// - bumps of a few millimetres that tilt the triangles 25-34 deg: a particle's own triangle is a
//   poor normal for the spacing-sized patch its tangent plane stands for. The normal is the
//   area-weighted mean of the triangles within half a spacing, over those within 60 deg of the
//   running mean, started from the particle's own triangle (a few mean-shift steps): bumps
//   average out, a true edge (90 deg) stays sharp, and on a flat face every triangle has the
//   same normal, so exact boxes keep theirs bit for bit.
#include <cmath>

#include "sampling_internal.hpp"

namespace demnerf::geometry::detail {
namespace {

constexpr double kConeCosine = 0.5;  ///< cos 60 deg: triangles of the same face
constexpr int kMeanShiftSteps = 3;
constexpr double kSolidShare = 0.6;  ///< above a concave edge's half, below a crack's

/// The faces' centroids, in face order (a point's id is its face).
PointGrid faceCentroids(const PreparedMesh& prepared, double cell) {
  const auto& m = prepared.mesh;
  PointGrid grid(prepared.bounds(), cell);
  for (const auto& idx : m.faces) grid.insert((m.vertices[idx[0]] + m.vertices[idx[1]] + m.vertices[idx[2]]) / 3.0);
  return grid;
}

Eigen::Vector3d patchNormal(const PreparedMesh& prepared, const PointGrid& centroids, const Eigen::Vector3d& x,
                            int face, double radius) {
  std::vector<int> near{face};
  centroids.forEachWithin(x, radius, [&](int f) {
    if (f != face) near.push_back(f);
  });
  const Eigen::Vector3d& own = prepared.normals[face];
  Eigen::Vector3d n = own;
  for (int step = 0; step < kMeanShiftSteps; ++step) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int f : near)
      if (prepared.normals[f].dot(n) >= kConeCosine) sum += prepared.face_areas[f] * prepared.normals[f];
    if (!(sum.norm() > 0)) break;
    n = sum.normalized();
  }
  // Rounding in the sum must not move a flat face's normal: exact surfaces keep theirs exactly.
  return (n - own).norm() < 1e-9 ? own : n;
}

/// Most of the half-ball of radius `spacing` in front of the particle is solid: its wall bounds a
/// gap (a crack, a pocket, a cavity's rim) thinner than the cloud resolves. Probed on a fixed
/// spread of directions at half and one spacing; a particle on a 90 deg concave edge sees at
/// most half solid, an outer face none.
bool solidInFront(const PreparedMesh& prepared, const Eigen::Vector3d& x, const Eigen::Vector3d& n, double spacing) {
  constexpr int kDirections = 64;
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  int probes = 0, solid = 0;
  for (int k = 0; k < kDirections; ++k) {
    const double z = 1.0 - (2.0 * k + 1.0) / kDirections, r = std::sqrt(1.0 - z * z);
    const Eigen::Vector3d d(r * std::cos(golden * k), r * std::sin(golden * k), z);
    if (d.dot(n) < 0.25) continue;
    for (double reach : {0.5 * spacing, spacing}) {
      ++probes;
      solid += prepared.inside.inside(x + reach * d);
    }
  }
  return solid > kSolidShare * probes;
}

}  // namespace

SurfaceFrames surfaceFrames(const PreparedMesh& prepared, const SampleSet& set, double spacing) {
  SurfaceFrames out;
  const double radius = 0.5 * spacing;
  const PointGrid centroids = faceCentroids(prepared, radius);
  out.normals.reserve(set.surface.size());
  out.crack_wall.reserve(set.surface.size());
  for (std::size_t s = 0; s < set.surface.size(); ++s) {
    const int face = set.surface_faces[s];
    out.normals.push_back(patchNormal(prepared, centroids, set.surface[s], face, radius));
    out.crack_wall.push_back(solidInFront(prepared, set.surface[s], prepared.normals[face], spacing));
  }
  return out;
}

}  // namespace demnerf::geometry::detail
