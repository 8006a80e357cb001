#include "demnerf/mechanics/particle_inside_test.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "demnerf/core/error.hpp"

namespace demnerf::mechanics {

ParticleInsideTest::ParticleInsideTest(const core::ParticleCloud& cloud, double reach) {
  if (cloud.size() == 0) throw core::Error("inside test: the particle cloud is empty");
  long carriers = 0;
  lower_ = cloud.positions[0];
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    lower_ = lower_.cwiseMin(cloud.positions[i]);
    if (cloud.volumes[i] > 0) {
      volume_ += cloud.volumes[i];
      ++carriers;
    }
  }
  if (carriers == 0) throw core::Error("inside test: no particle carries a volume");
  spacing_ = std::cbrt(volume_ / static_cast<double>(carriers));
  bucket_ = spacing_;
  reach_ = reach * spacing_;
  positions_ = cloud.positions;
  normals_ = cloud.normals;
  surface_.resize(cloud.size());
  carries_.resize(cloud.size());
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    surface_[i] = cloud.isSurface(i) && cloud.normals[i].squaredNorm() > 0.25;
    carries_[i] = cloud.volumes[i] > 0;
    if (surface_[i]) surface_area_ += cloud.areas[i];
  }
  // Buckets one spacing wide over the particles' box, as a CSR table (counting sort).
  Eigen::Vector3d upper = lower_;
  for (const auto& p : positions_) upper = upper.cwiseMax(p);
  const Eigen::Vector3d extent = ((upper - lower_) / bucket_).array().floor() + 1.0;
  const double buckets = extent.prod();
  if (!(buckets <= 2e8))
    throw core::Error("inside test: the particles span " + std::to_string(buckets) +
                      " buckets of one spacing; the cloud is far too sparse for its extent");
  dims_ = extent.cast<int>();
  start_.assign(static_cast<std::size_t>(buckets) + 1, 0);
  std::vector<long> of(positions_.size());
  for (std::size_t i = 0; i < positions_.size(); ++i) {
    of[i] = bucketIndex(bucket(positions_[i]));
    ++start_[of[i] + 1];
  }
  for (std::size_t b = 1; b < start_.size(); ++b) start_[b] += start_[b - 1];
  members_.resize(positions_.size());
  std::vector<long> fill(start_.begin(), start_.end() - 1);
  for (std::size_t i = 0; i < positions_.size(); ++i) members_[fill[of[i]]++] = static_cast<int>(i);
  surface_start_.assign(start_.size(), 0);
  for (std::size_t i = 0; i < positions_.size(); ++i) surface_start_[of[i] + 1] += surface_[i];
  for (std::size_t b = 1; b < surface_start_.size(); ++b) surface_start_[b] += surface_start_[b - 1];
  surface_members_.resize(static_cast<std::size_t>(surface_start_.back()));
  fill.assign(surface_start_.begin(), surface_start_.end() - 1);
  for (std::size_t i = 0; i < positions_.size(); ++i)
    if (surface_[i]) surface_members_[fill[of[i]]++] = static_cast<int>(i);
  markRough();
}

// A surface particle is rough when a same-face neighbour within the blend's reach lies off its
// plane and it lies off the neighbour's: two planes that cross between them. Exact bodies' faces are
// flat, so none of their particles is rough and their distances stay the nearest plane's, bit for
// bit. Both ways, because a sampler's particle on an edge carries a normal between the faces' (Cook's
// random 1/10 cloud: one at the bottom-right corner, 11 degrees from the bottom face's): the bottom
// face's particles lie off its plane, but it lies on theirs.
void ParticleInsideTest::markRough() {
  rough_.assign(positions_.size(), 0);
  const double radius = kBlendRadius * spacing_;
  const double flat = 1e-9 * spacing_;
  for (std::size_t i = 0; i < positions_.size(); ++i) {
    if (!surface_[i]) continue;
    const Eigen::Vector3d& p = positions_[i];
    const Eigen::Vector3d& n = normals_[i];
    forEachSurfaceNear(bucket(p), [&](int j) {
      if (normals_[j].dot(n) >= kSameFace && (positions_[j] - p).squaredNorm() <= radius * radius &&
          std::abs((positions_[j] - p).dot(n)) > flat && std::abs((p - positions_[j]).dot(normals_[j])) > flat)
        rough_[i] = 1;
    });
  }
}

std::size_t ParticleInsideTest::roughParticles() const {
  return static_cast<std::size_t>(std::count(rough_.begin(), rough_.end(), 1));
}

double ParticleInsideTest::roughShare() const {
  const auto surface = std::count(surface_.begin(), surface_.end(), 1);
  return surface == 0 ? 0.0 : static_cast<double>(roughParticles()) / static_cast<double>(surface);
}

long ParticleInsideTest::bucketIndex(const Eigen::Vector3i& c) const {
  if ((c.array() < 0).any() || (c.array() >= dims_.array()).any()) return -1;
  return (static_cast<long>(c(2)) * dims_(1) + c(1)) * dims_(0) + c(0);
}

template <typename Visit>
void ParticleInsideTest::forEachIn(const Eigen::Vector3i& c, Visit&& visit) const {
  const long b = bucketIndex(c);
  if (b < 0) return;
  for (long k = start_[b]; k < start_[b + 1]; ++k) visit(members_[k]);
}

// A row of buckets along x is contiguous in the table: one range per (z, y), clipped to the table.
template <typename Visit>
void ParticleInsideTest::forEachSurfaceNear(const Eigen::Vector3i& c, Visit&& visit) const {
  const Eigen::Vector3i lo = (c.array() - kNearRings).max(0);
  const Eigen::Vector3i hi = (c.array() + kNearRings).min(dims_.array() - 1);
  // A point more than kNearRings buckets outside the table has no surface near it; the x range
  // below is read as one slice of the row, which must not start past its end.
  if ((lo.array() > hi.array()).any()) return;
  for (int z = lo(2); z <= hi(2); ++z)
    for (int y = lo(1); y <= hi(1); ++y) {
      const long row = (static_cast<long>(z) * dims_(1) + y) * dims_(0);
      for (long k = surface_start_[row + lo(0)]; k < surface_start_[row + hi(0) + 1]; ++k) visit(surface_members_[k]);
    }
}

void ParticleInsideTest::surfaceNeighbours(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi,
                                           SurfaceNeighbours& out) const {
  out.lo = bucket(lo);
  out.hi = bucket(hi);
  out.index.clear();
  out.bucket.clear();
  const Eigen::Vector3i a = (out.lo.array() - kNearRings).max(0);
  const Eigen::Vector3i b = (out.hi.array() + kNearRings).min(dims_.array() - 1);
  for (int z = a(2); z <= b(2); ++z)
    for (int y = a(1); y <= b(1); ++y)
      for (int x = a(0); x <= b(0); ++x) {
        const long at = (static_cast<long>(z) * dims_(1) + y) * dims_(0) + x;
        for (long k = surface_start_[at]; k < surface_start_[at + 1]; ++k) {
          out.index.push_back(surface_members_[k]);
          out.bucket.emplace_back(x, y, z);
        }
      }
}

// The gathered particles in bucket order are the window's in the same order, so the nearest one
// and the edge planes' max / min (an order-dependent sequence) come out as signedDistance(x)'s.
double ParticleInsideTest::signedDistance(const Eigen::Vector3d& x, const SurfaceNeighbours& near) const {
  const Eigen::Vector3i c = bucket(x);
  if ((c.array() < near.lo.array()).any() || (c.array() > near.hi.array()).any()) return signedDistance(x, nullptr);
  const auto nearby = [&](auto&& visit) {
    for (std::size_t k = 0; k < near.index.size(); ++k)
      if ((near.bucket[k] - c).cwiseAbs().maxCoeff() <= kNearRings) visit(near.index[k]);
  };
  double d = 0.0;
  if (nearSurface(x, nearby, nullptr, d)) return d;
  return deepSide(x, c);
}

Eigen::Vector3i ParticleInsideTest::bucket(const Eigen::Vector3d& x) const {
  return ((x - lower_) / bucket_).array().floor().cast<int>();
}

bool ParticleInsideTest::inside(const Eigen::Vector3d& x) const { return signedDistance(x, nullptr) <= 0.0; }

double ParticleInsideTest::signedDistance(const Eigen::Vector3d& x, Eigen::Vector3d* normal) const {
  if (normal) normal->setZero();
  const Eigen::Vector3i c = bucket(x);
  const auto nearby = [&](auto&& visit) { forEachSurfaceNear(c, visit); };
  double d = 0.0;
  if (nearSurface(x, nearby, normal, d)) return d;
  return deepSide(x, c);
}

// Near the surface: the side of the nearest surface particle's tangent plane (moved out by the
// surface offset). Nearest, not a weighted blend of every face's planes: that rounds convex edges by
// about a spacing (4 % of a unit cube's volume at 12 particles per edge); on a rough face only that
// face's planes are blended (blendedDistance).
template <typename Nearby>
bool ParticleInsideTest::nearSurface(const Eigen::Vector3d& x, Nearby&& nearby, Eigen::Vector3d* normal,
                                     double& d) const {
  int nearest = -1;
  double nearest_d2 = kSurfaceRadius * kSurfaceRadius * spacing_ * spacing_;
  nearby([&](int i) {
    const double d2 = (x - positions_[i]).squaredNorm();
    if (d2 < nearest_d2) {
      nearest_d2 = d2;
      nearest = i;
    }
  });
  if (nearest < 0) return false;
  int active = nearest;
  d = distanceNear(x, nearest, nearby, active);
  if (normal) *normal = normals_[active].normalized();
  // Behind some tangent plane, yet farther from every surface particle than an inside point is
  // from some particle (deepSide()'s rule): a plane extended past where its face ends. In the
  // re-entrant corners of the NeRF T-bar's 1/6 clouds (10 mm), under the crossbar beside the stem,
  // points 16-19 mm from every particle counted as body (0.3-0.5 cm^3 of them); a finer grid's
  // first Hessian was indefinite there (7 Newton iterations instead of 4; docs/dem_feature_grid.md).
  const double deep = kDeepReach * spacing_;
  if (d <= 0 && nearest_d2 > deep * deep) {
    const double carrier = nearestCarrier(x, bucket(x));
    if (carrier > deep) d = carrier - deep;
  }
  return true;
}

double ParticleInsideTest::nearestCarrier(const Eigen::Vector3d& x, const Eigen::Vector3i& c) const {
  const int rings = static_cast<int>(std::ceil(kDeepReach * spacing_ / bucket_)) + 1;
  double best = std::numeric_limits<double>::infinity();
  for (int z = -rings; z <= rings; ++z)
    for (int y = -rings; y <= rings; ++y)
      for (int xx = -rings; xx <= rings; ++xx)
        forEachIn(c + Eigen::Vector3i(xx, y, z), [&](int i) {
          if (carries_[i]) best = std::min(best, (positions_[i] - x).squaredNorm());
        });
  return std::sqrt(best);
}

double ParticleInsideTest::deepSide(const Eigen::Vector3d& x, const Eigen::Vector3i& c) const {
  // Away from the surface: the nearest particle within reach must carry volume (found in shells
  // of buckets; shell r holds every particle closer than r buckets).
  const int rings = static_cast<int>(std::ceil(reach_ / bucket_)) + 1;
  int best = -1;
  double best_d = std::numeric_limits<double>::infinity();
  for (int r = 0; r <= rings; ++r) {
    for (int z = -r; z <= r; ++z)
      for (int y = -r; y <= r; ++y)
        for (int xx = -r; xx <= r; ++xx) {
          if (std::max({std::abs(z), std::abs(y), std::abs(xx)}) != r) continue;
          forEachIn(c + Eigen::Vector3i(xx, y, z), [&](int i) {
            const double d = (positions_[i] - x).squaredNorm();
            if (d < best_d) {
              best_d = d;
              best = i;
            }
          });
        }
    if (best >= 0 && std::sqrt(best_d) <= r * bucket_) break;
  }
  // Deeper than the surface particles reach: only the side is known. Interior particles of a
  // random cloud lie arbitrarily close under the surface, so a point outside a gap between surface
  // particles (none within kSurfaceRadius) can have an interior particle nearest: within the full
  // reach that counted bands up to 3 spacings outside a face as body (+0.5-1.3 % of the T-bar's
  // volume on random clouds). Inside a cloud some particle is nearly always within kDeepReach
  // spacings (a random cloud leaves a hole that large with probability e^-14), so with surface
  // particles present that is the reach; without any, the caller's.
  const double reach = surface_area_ > 0 ? std::min(reach_, kDeepReach * spacing_) : reach_;
  const double far = (kSurfaceRadius + 1.0) * spacing_;
  return best >= 0 && std::sqrt(best_d) <= reach && carries_[best] ? -far : far;
}

// On a rough face (a NeRF extraction's), the planes of the nearest particle's same-face neighbours
// (normals within 30 degrees) within kBlendRadius spacings, blended by weights that grow as 1 / r^2
// near a particle (so the blend passes through each particle's plane there, as an IMLS surface)
// and fall to zero at the radius. The nearest plane alone is piecewise: on a surface curved by bumps
// it lies outside where the surface is convex and inside where it is concave, a skin of both false
// inside and false outside volume (2-3 % each of the NeRF T-bar's on its 1/6 clouds). Other faces
// do not join the blend (that would round convex edges by a spacing); the edge rule below sees them.
template <typename Nearby>
double ParticleInsideTest::blendedDistance(const Eigen::Vector3d& x, int nearest, Nearby&& nearby) const {
  const Eigen::Vector3d& n = normals_[nearest];
  const double h2 = kBlendRadius * kBlendRadius * spacing_ * spacing_;
  double sum = 0.0, weights = 0.0;
  nearby([&](int j) {
    if (normals_[j].dot(n) < kSameFace) return;
    const double r2 = (x - positions_[j]).squaredNorm() / h2;
    if (r2 >= 1.0) return;
    const double t = (1.0 - r2) * (1.0 - r2);
    const double w = t * t / (r2 + 1e-4);
    sum += w * ((x - positions_[j]).dot(normals_[j]) - offset_);
    weights += w;
  });
  return sum / weights;  // the nearest particle is within the radius: weights > 0
}

// Where faces meet, the nearest surface particle can sit on the other face: a point just outside a
// convex edge then lies behind that face's plane and would count as inside (a band of about half a
// spacing along every convex edge: +5.6 % of the T-bar's volume from a Poisson cloud at 14 mm).
// So the planes of the surface particles about as near whose normals turn by more than 60 degrees
// join in: across a convex edge (each particle behind the other's plane) the point must be behind
// both, across a concave one behind either. As distances to the planes: the larger across a convex
// edge (the intersection of the half-spaces), the smaller across a concave one (their union). A
// particle lying on the other's plane is on the edge itself (a lattice's line crossing there,
// carrying one face's normal): with the other strictly behind its plane the edge is convex. Read
// as neither, such a particle's plane reached past the edge and claimed a strip beyond the other
// face (a grid T-bar whose 360 edge particles made the DEM 0.43 points stiff). Two particles that
// each lie on the other's plane are both on the edge line (a lattice's lines of both faces meet
// there) and say nothing of its sense: read as concave (their union), such pairs claimed the
// strips beyond the grid T-bar's convex top edges at the bar's ends (3.0 cm^3), so they are left
// out and the pairs with a particle off the edge decide. "On the plane" stays within 1e-9 of a
// spacing: 1e-4, wide enough for the float offsets of a PLY-stored lattice, also joins pairs of
// the NeRF T-bar's clouds that lie that close by chance (docs/dem_feature_grid.md, "The inside test
// at edges").
template <typename Nearby>
double ParticleInsideTest::distanceNear(const Eigen::Vector3d& x, int nearest, Nearby&& nearby, int& active) const {
  const auto distance = [&](int i) { return (x - positions_[i]).dot(normals_[i]) - offset_; };
  const Eigen::Vector3d& p = positions_[nearest];
  const Eigen::Vector3d& n = normals_[nearest];
  const double reach = (x - p).norm() + edge_reach_ * spacing_;
  const double on_plane = 1e-9 * spacing_;
  double d = blend_rough_ && rough_[nearest] ? blendedDistance(x, nearest, nearby) : distance(nearest);
  nearby([&](int j) {
    if (normals_[j].dot(n) >= kEdgeCosine || (x - positions_[j]).squaredNorm() > reach * reach) return;
    const double j_ahead = (positions_[j] - p).dot(n);             // of the nearest's plane
    const double nearest_ahead = (p - positions_[j]).dot(normals_[j]);  // of j's plane
    if (std::abs(j_ahead) <= on_plane && std::abs(nearest_ahead) <= on_plane) return;  // both on the edge line
    // With both on the line left out, the two cases cannot overlap: one particle is off the other's plane.
    const bool convex = j_ahead <= on_plane && nearest_ahead <= on_plane;
    const bool concave = j_ahead >= -on_plane && nearest_ahead >= -on_plane;
    const double dj = distance(j);
    if ((convex && dj > d) || (concave && dj < d)) {
      d = dj;
      active = j;
    }
  });
  return d;
}

}  // namespace demnerf::mechanics
