#include "demnerf/mechanics/surface_loads.hpp"

#include <algorithm>
#include <cmath>

#include "demnerf/core/error.hpp"
#include "demnerf/mechanics/boundary_conditions.hpp"
#include "demnerf/mechanics/dirichlet_lift.hpp"
#include "demnerf/mechanics/loaded_share.hpp"
#include "demnerf/mechanics/particle_inside_test.hpp"

namespace demnerf::mechanics {
namespace {

// A lattice that covers the region near the body: the region's box (the body's for a half-space)
// cut to the particles' box, both grown by two steps. A region much larger than the patch it loads
// (a half-space, or a box around the whole body, with a fine grid) would need a lattice over the
// whole body: the step grows until it holds at most kMaxProbes points (a few seconds of probes).
struct Lattice {
  Eigen::Vector3d lo;
  Eigen::Vector3i n = Eigen::Vector3i::Zero();
  double step = 0.0;
};

constexpr double kMaxProbes = 4e6;

Lattice latticeFor(const core::Region& region, const Eigen::Vector3d& body_lo, const Eigen::Vector3d& body_hi,
                   double step) {
  Eigen::Vector3d lo = body_lo, hi = body_hi;
  if (region.type == core::Region::Type::kBox) {
    lo = lo.cwiseMax(region.center - 0.5 * region.size);
    hi = hi.cwiseMin(region.center + 0.5 * region.size);
  } else if (region.type == core::Region::Type::kSphere) {
    lo = lo.cwiseMax(region.center - Eigen::Vector3d::Constant(region.radius));
    hi = hi.cwiseMin(region.center + Eigen::Vector3d::Constant(region.radius));
  }
  Lattice lattice;
  for (;;) {
    const Eigen::Vector3d extent = hi - lo + Eigen::Vector3d::Constant(4 * step);
    if ((extent.array() <= 0).any()) return lattice;
    const Eigen::Vector3d count = (extent / step).array().ceil();
    if (count.prod() > kMaxProbes) {
      step *= 1.01 * std::cbrt(count.prod() / kMaxProbes);
      continue;
    }
    lattice.lo = lo - Eigen::Vector3d::Constant(2 * step);
    lattice.n = count.cast<int>();
    lattice.step = step;
    return lattice;
  }
}

// The inside test's edge join for the loads (ParticleInsideTest::setEdgeReach): beside a gap in a
// random cloud's face particles near an edge, a point just outside the face had the other face's
// particle nearest and its own face's beyond one spacing more, so the band outside counted as
// surface (the random cuboid's corner bins took 18 % too much torque); two spacings close it.
constexpr double kLoadEdgeReach = 2.0;

// The points of one load's patch and their areas (surfaceLoads()).
void patchPoints(const core::Region& region, const ParticleInsideTest& inside, const Lattice& lattice,
                 std::vector<Eigen::Vector3d>& points, std::vector<double>& areas) {
  const double step = lattice.step;
  for (int k = 0; k < lattice.n(2); ++k)
    for (int j = 0; j < lattice.n(1); ++j)
      for (int i = 0; i < lattice.n(0); ++i) {
        const Eigen::Vector3d p = lattice.lo + step * Eigen::Vector3d(i + 0.5, j + 0.5, k + 0.5);
        if (regionDistance(region, p) > 2 * step) continue;
        Eigen::Vector3d n;
        double d = inside.signedDistance(p, &n);
        if (!(std::abs(d) < step) || n.isZero()) continue;
        // The foot of the nearest plane can lie beyond another face: across a convex edge whose
        // other face's particles the inside test did not join (a gap in a random cloud's face
        // wider than kLoadEdgeReach), the nearest plane extends past the edge, and a point outside
        // the other face would count as near the surface. When the foot lies outside a face that
        // turns by more than 60 degrees (an edge, not the facets of a curved surface), the point
        // is at least as far from the surface as the foot.
        Eigen::Vector3d q = p - d * n, nq = n;
        for (int again = 0; again < 3; ++again) {
          Eigen::Vector3d next;
          const double dq = inside.signedDistance(q, &next);
          if (again == 0 && dq > 0 && next.dot(n) < ParticleInsideTest::kEdgeCosine) d = std::max(d, dq);
          if (!(std::abs(dq) > 1e-9 * step) || next.isZero()) break;
          q -= dq * next;  // a few more projections take the foot onto the surface (the edge)
          nq = next;
        }
        if (!(std::abs(d) < step)) continue;
        // The point stands for a lattice cell's footprint, a square of side `step` on the surface:
        // clipped to the region as a particle's area is (loadedShare(), with its rounding
        // tolerance), so a region's edge is resolved below the step.
        const double share = loadedShare(region, q, nq, step * step);
        if (!(share > 0.0)) continue;
        points.push_back(q);
        areas.push_back(share * (1.0 - std::abs(d) / step) * step * step);
      }
}

}  // namespace

SurfaceLoads surfaceLoads(const core::Scenario& scenario, const core::ParticleCloud& cloud, double step) {
  if (!(step > 0)) throw core::Error("surface loads: the lattice step must be > 0");
  SurfaceLoads out;
  if (scenario.loads.empty()) return out;
  ParticleInsideTest inside(cloud);
  inside.setEdgeReach(kLoadEdgeReach);
  Eigen::Vector3d lo = cloud.positions[0], hi = lo;
  for (const Eigen::Vector3d& p : cloud.positions) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  for (const core::Load& load : scenario.loads) {
    std::vector<Eigen::Vector3d> points;
    std::vector<double> areas;
    patchPoints(load.region, inside, latticeFor(load.region, lo, hi, step), points, areas);
    if (points.empty()) {
      // particleTractions() names a region that holds no surface particle; one that holds some but
      // is finer than the lattice keeps its particles' forces.
      core::Scenario one = scenario;
      one.loads = {load};
      const std::vector<Eigen::Vector3d> traction = particleTractions(one, cloud);
      for (std::size_t i = 0; i < cloud.size(); ++i)
        if (cloud.areas[i] > 0 && traction[i].squaredNorm() > 0) {
          out.points.push_back(cloud.positions[i]);
          out.forces.push_back(cloud.areas[i] * traction[i]);
        }
      continue;
    }
    const WrenchTraction field = spreadWrench(points, areas, load.force, load.torque, "load '" + load.name + "'");
    for (std::size_t k = 0; k < points.size(); ++k) {
      out.points.push_back(points[k]);
      out.forces.push_back(areas[k] * field.at(points[k]));
    }
  }
  return out;
}

}  // namespace demnerf::mechanics
