#include "demnerf/mechanics/cell_quadrature.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <exception>
#include <limits>

#include "demnerf/core/error.hpp"
#include "demnerf/mechanics/dirichlet_lift.hpp"
#include "demnerf/mechanics/particle_inside_test.hpp"
#include "parallel_for.hpp"

namespace demnerf::mechanics {
namespace {

// Gauss-Legendre nodes on [0, 1] and their weights (summing to 1).
void gaussRule(int n, std::vector<double>& t, std::vector<double>& w) {
  switch (n) {
    case 1: t = {0.5}, w = {1.0}; return;
    case 2: {
      const double a = 0.5 / std::sqrt(3.0);
      t = {0.5 - a, 0.5 + a}, w = {0.5, 0.5};
      return;
    }
    default: {
      const double a = 0.5 * std::sqrt(0.6);
      t = {0.5 - a, 0.5, 0.5 + a}, w = {5.0 / 18.0, 8.0 / 18.0, 5.0 / 18.0};
    }
  }
}

class CellIntegrator {
 public:
  CellIntegrator(const ParticleInsideTest& inside, const CellQuadratureConfig& config)
      : inside_(inside), levels_(config.boundary_levels), held_(config.held_volumes) {
    gaussRule(config.points_per_axis, t_, w_);
  }

  // Signed distance to the union of the held volumes (+inf without any). Its magnitude never
  // exceeds the distance to the union's boundary, so a cube farther than its half diagonal from
  // that boundary by this measure is not cut by it.
  double heldDistance(const Eigen::Vector3d& x) const {
    double d = std::numeric_limits<double>::infinity();
    for (const core::Region& r : held_) d = std::min(d, regionSignedDistance(r, x));
    return d;
  }

  // Adds the Gauss points of the cube [lo, lo + edge] that lie inside; a cube whose probes (its
  // Gauss points and corners) disagree is split while levels remain, and at the last level gets
  // one point at the centroid of its inside part (found on a lattice of probes) weighted by that
  // part's volume: exact for linear integrands, so the volume and first moments of the body near
  // its surface come out right whatever the cells' alignment.
  void add(const Eigen::Vector3d& lo, double edge, int level, CellQuadrature& out) const {
    std::vector<Eigen::Vector3d> points;
    std::vector<double> weights;
    std::vector<char> in;
    const int n = static_cast<int>(t_.size());
    int inside_count = 0;
    for (int k = 0; k < n; ++k)
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
          points.push_back(lo + edge * Eigen::Vector3d(t_[i], t_[j], t_[k]));
          weights.push_back(w_[i] * w_[j] * w_[k] * edge * edge * edge);
          in.push_back(inside_.inside(points.back()));
          inside_count += in.back();
        }
    bool mixed = inside_count > 0 && inside_count < n * n * n;
    for (int c = 0; c < 8 && !mixed; ++c) {
      const Eigen::Vector3d corner = lo + edge * Eigen::Vector3d(c & 1, (c >> 1) & 1, (c >> 2) & 1);
      mixed = inside_.inside(corner) != (inside_count > 0);
    }
    // A held volume's boundary through a cell the body fills (in part) is a cut as well: D = 0 in
    // the held part, so its Gauss points see nothing of the field, and a cell straddling the
    // boundary whose points all fall inside the held part leaves its free strip unintegrated (the
    // cuboid's halfspace clamp x <= 15 mm in a [0, 20] mm cell: a 9 mm strip where the field was
    // free to invert). Such cells are split like surface-cut ones, and at the last level the free
    // and the held part are moment-fitted apart, so the free part of every cell carries points.
    const bool held_cut = (inside_count > 0 || mixed) &&
                          std::abs(heldDistance(lo + 0.5 * edge * Eigen::Vector3d::Ones())) < 0.5 * std::sqrt(3.0) * edge;
    if ((mixed || held_cut) && level < levels_) {
      const double half = 0.5 * edge;
      for (int c = 0; c < 8; ++c)
        add(lo + half * Eigen::Vector3d(c & 1, (c >> 1) & 1, (c >> 2) & 1), half, level + 1, out);
      return;
    }
    if (held_cut) {
      addCutCell(lo, edge, out, [this](const Eigen::Vector3d& p, const ParticleInsideTest::SurfaceNeighbours& near) {
        return std::max(inside_.signedDistance(p, near), -heldDistance(p));
      });
      addCutCell(lo, edge, out, [this](const Eigen::Vector3d& p, const ParticleInsideTest::SurfaceNeighbours& near) {
        return std::max(inside_.signedDistance(p, near), heldDistance(p));
      });
      return;
    }
    if (mixed) {
      addCutCell(lo, edge, out, [this](const Eigen::Vector3d& p, const ParticleInsideTest::SurfaceNeighbours& near) {
        return inside_.signedDistance(p, near);
      });
      return;
    }
    for (std::size_t p = 0; p < points.size(); ++p)
      if (in[p]) {
        out.points.push_back(points[p]);
        out.weights.push_back(weights[p]);
      }
  }

  // Gauss points over the box that bounds the sub-cell's inside part, with weights fitted to the
  // part: w_g is the integral over the part of the Lagrange polynomial that is 1 at Gauss point g
  // and 0 at the others (summed over a lattice of probes), so the rule integrates the tensor
  // polynomials of the Gauss rule's order exactly over the part (moment fitting). Every point keeps
  // a weight, so the (degree + 1)^3 functions that meet there stay distinguishable: one point at
  // the part's centroid leaves them soft modes (55 % error on a stretched cube). The tight box keeps
  // the weights of slab-like parts positive.
  // `distance` is the part's signed distance (the body's, or the body's less or within the held volumes).
  template <class SignedDistance>
  void addCutCell(const Eigen::Vector3d& lo, double edge, CellQuadrature& out, const SignedDistance& distance) const {
    constexpr int kProbes = 6;  // per axis
    const double probe = edge / kProbes;
    // Each probe counts with the share of its cube behind the surface, from the signed distance
    // at its centre (exact for a face parallel to the cube's sides): counted whole or not at all,
    // the probes quantise a face's position to a sixth of the sub-cell, and on the T-bar's 15 mm
    // cells that lost 1.3 % of the volume on every cloud alike (the faces sat 0.19 mm inside).
    // The probes share their candidates, the surface particles near the sub-cell: gathered once,
    // the same distances as a search per probe (most of the T-bar's set-up was that search).
    ParticleInsideTest::SurfaceNeighbours near;
    inside_.surfaceNeighbours(lo, lo + Eigen::Vector3d::Constant(edge), near);
    std::vector<Eigen::Vector3d> inside;
    std::vector<double> fill;
    Eigen::Vector3d box_lo = lo + Eigen::Vector3d::Constant(edge), box_hi = lo;
    for (int k = 0; k < kProbes; ++k)
      for (int j = 0; j < kProbes; ++j)
        for (int i = 0; i < kProbes; ++i) {
          const Eigen::Vector3d p = lo + probe * (Eigen::Vector3d(i, j, k) + Eigen::Vector3d::Constant(0.5));
          const double share = std::clamp(0.5 - distance(p, near) / probe, 0.0, 1.0);
          if (!(share > 0.0)) continue;
          inside.push_back(p);
          fill.push_back(share);
          box_lo = box_lo.cwiseMin(p);
          box_hi = box_hi.cwiseMax(p);
        }
    if (inside.empty()) return;
    box_lo -= Eigen::Vector3d::Constant(0.5 * probe);
    box_hi += Eigen::Vector3d::Constant(0.5 * probe);
    const Eigen::Vector3d size = box_hi - box_lo;
    const int n = static_cast<int>(t_.size());
    std::vector<double> fitted(n * n * n, 0.0);
    const double probe_volume = probe * probe * probe;
    double inside_volume = 0.0;
    std::vector<double> L[3];
    for (std::size_t q = 0; q < inside.size(); ++q) {
      const Eigen::Vector3d& p = inside[q];
      const double v = probe_volume * fill[q];
      inside_volume += v;
      for (int a = 0; a < 3; ++a) L[a] = lagrange((p(a) - box_lo(a)) / size(a));
      for (int c = 0; c < n; ++c)
        for (int b = 0; b < n; ++b)
          for (int a = 0; a < n; ++a) fitted[(c * n + b) * n + a] += v * L[0][a] * L[1][b] * L[2][c];
    }
    // Negative weights (a part that fills a corner of its box) would make the energy non-convex
    // there: they are dropped and the rest rescaled to the part's volume.
    double positive = 0.0;
    for (double& w : fitted) positive += (w = std::max(w, 0.0));
    if (!(positive > 0)) return;
    for (int c = 0; c < n; ++c)
      for (int b = 0; b < n; ++b)
        for (int a = 0; a < n; ++a) {
          const double w = fitted[(c * n + b) * n + a];
          if (w <= 0) continue;
          out.points.push_back(box_lo + size.cwiseProduct(Eigen::Vector3d(t_[a], t_[b], t_[c])));
          out.weights.push_back(w * inside_volume / positive);
        }
  }

  // The Lagrange polynomials of the Gauss nodes t_ at s.
  std::vector<double> lagrange(double s) const {
    std::vector<double> L(t_.size(), 1.0);
    for (std::size_t a = 0; a < t_.size(); ++a)
      for (std::size_t b = 0; b < t_.size(); ++b)
        if (a != b) L[a] *= (s - t_[b]) / (t_[a] - t_[b]);
    return L;
  }

 private:
  const ParticleInsideTest& inside_;
  int levels_;
  const std::vector<core::Region>& held_;
  std::vector<double> t_, w_;
};

CellQuadrature integrateCells(const ParticleInsideTest& inside, const BsplineGrid& grid,
                              const CellQuadratureConfig& config) {
  const CellIntegrator integrator(inside, config);
  const Eigen::Vector3i cells = grid.cells();
  // The inside test's probes of the cut cells are most of a T-bar solve's setup: the cells are
  // split between the cores, each chunk's points appended in cell order.
  const int threads = assemblyThreads(config.threads);
  std::vector<CellQuadrature> parts(threads);
  // Chunk 0 runs on the calling thread and reports its share done for all (the chunks are equal);
  // when the report throws, every chunk stops at its next cell and the error is rethrown here.
  std::atomic<bool> stop{false};
  std::exception_ptr failure;
  parallelChunks(static_cast<long>(cells.prod()), threads, [&](int chunk, long begin, long end) {
    const long every = std::max(1L, (end - begin) / 100);
    for (long c = begin; c < end && !stop.load(std::memory_order_relaxed); ++c) {
      if (chunk == 0 && config.progress && (c - begin) % every == 0) {
        try {
          config.progress(static_cast<double>(c - begin) / static_cast<double>(end - begin));
        } catch (...) {
          failure = std::current_exception();
          stop = true;
          return;
        }
      }
      const Eigen::Vector3d index(c % cells(0), (c / cells(0)) % cells(1), c / (cells(0) * cells(1)));
      integrator.add(grid.origin() + grid.cell() * index, grid.cell(), 0, parts[chunk]);
    }
  });
  if (failure) std::rethrow_exception(failure);
  CellQuadrature out;
  for (const CellQuadrature& part : parts) {
    out.points.insert(out.points.end(), part.points.begin(), part.points.end());
    out.weights.insert(out.weights.end(), part.weights.begin(), part.weights.end());
  }
  for (double w : out.weights) out.raw_volume += w;
  if (out.points.empty() || !(out.raw_volume > 0))
    throw core::Error("cell quadrature: no Gauss point of the " + std::to_string(cells.prod()) +
                      " grid cells lies inside the body the particles describe");
  return out;
}

}  // namespace

CellQuadrature cellQuadrature(const core::ParticleCloud& cloud, const BsplineGrid& grid,
                              const CellQuadratureConfig& config) {
  if (config.points_per_axis < 1 || config.points_per_axis > 3 || config.boundary_levels < 0 ||
      config.boundary_levels > 4)
    throw core::Error("cell quadrature: points_per_axis must be 1-3 and boundary_levels 0-4");
  ParticleInsideTest inside(cloud);
  CellQuadrature out = integrateCells(inside, grid, config);
  // A lattice cloud whose surface particles carry a cell of volume each describes a body larger
  // than its particles' hull (the FEM voxelises it so): the surface moves out until the volumes
  // agree. Sampled clouds (surface particles on the surface, without volume) need no move.
  const double offset = inside.surfaceArea() > 0 ? (inside.volume() - out.raw_volume) / inside.surfaceArea() : 0.0;
  if (std::abs(offset) > 0.1 * inside.spacing()) {
    inside.setSurfaceOffset(std::clamp(offset, -0.5 * inside.spacing(), inside.spacing()));
    out = integrateCells(inside, grid, config);
  }
  // The particles' volumes are the sampler's estimate of the body's volume (exact for meshes it
  // sampled); the cells' inside test resolves the surface only to a sub-cell.
  const double scale = inside.volume() / out.raw_volume;
  for (double& w : out.weights) w *= scale;
  return out;
}

}  // namespace demnerf::mechanics
