#include "demnerf/render/deformed_renderer.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "demnerf/core/error.hpp"
#include "demnerf/nerf/ray_marcher.hpp"

namespace demnerf::render {
namespace {

std::string vec(const Eigen::Vector3d& v) {
  std::ostringstream s;
  s << "(" << v.x() << ", " << v.y() << ", " << v.z() << ")";
  return s.str();
}

std::string boxText(const nerf::Box& b) {
  return vec(Eigen::Vector3d(b.min[0], b.min[1], b.min[2])) + " .. " + vec(Eigen::Vector3d(b.max[0], b.max[1], b.max[2]));
}

/// Whether the NeRF's occupancy grid marks the cell of p or one of its 26 neighbours: surface
/// particles sit on the boundary of the occupied cells.
bool nearOccupied(const nerf::OccupancyGrid& grid, const Eigen::Vector3d& p) {
  const nerf::Box& b = grid.bounds();
  const int r = grid.resolution();
  int c[3];
  for (int a = 0; a < 3; ++a) {
    const double u = (p[a] - b.min[a]) / b.size(a);
    if (!(u >= 0 && u <= 1)) return false;
    c[a] = std::min(static_cast<int>(u * r), r - 1);
  }
  for (int z = std::max(0, c[2] - 1); z <= std::min(r - 1, c[2] + 1); ++z)
    for (int y = std::max(0, c[1] - 1); y <= std::min(r - 1, c[1] + 1); ++y)
      for (int x = std::max(0, c[0] - 1); x <= std::min(r - 1, c[0] + 1); ++x)
        if (grid.occupied((static_cast<std::int64_t>(z) * r + y) * r + x)) return true;
  return false;
}

/// Checks the result against the model before any tetrahedron is built; returns it.
const core::ResultField& checked(const nerf::NerfModel& model, const core::ResultField& result,
                                 const DeformedRenderConfig& config) {
  const std::size_t n = result.positions.size();
  if (n == 0) throw core::Error("deformed render: the result has no particles (empty or unreadable result file)");
  if (config.expected_particles && n != config.expected_particles) {
    throw core::Error("deformed render: the result has " + std::to_string(n) + " particles but the body has " +
                      std::to_string(config.expected_particles) + "; was it computed on another particle cloud?");
  }
  if (result.displacements.size() != n) {
    throw core::Error("deformed render: the result has " + std::to_string(n) + " positions but " +
                      std::to_string(result.displacements.size()) + " displacements");
  }
  const nerf::Box box = model.bounds();
  std::size_t outside = 0, first_outside = n, occupied = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d& p = result.positions[i];
    if (!p.allFinite() || !result.displacements[i].allFinite()) {
      throw core::Error("deformed render: result particle " + std::to_string(i) + " is not finite: position " +
                        vec(p) + ", displacement " + vec(result.displacements[i]));
    }
    bool inside = true;
    for (int a = 0; a < 3; ++a) {
      const double pad = 1e-3 * box.size(a);
      inside = inside && p[a] >= box.min[a] - pad && p[a] <= box.max[a] + pad;
    }
    if (!inside) {
      if (first_outside == n) first_outside = i;
      ++outside;
    } else if (nearOccupied(model.grid(), p)) {
      ++occupied;
    }
  }
  if (outside > 0) {
    throw core::Error("deformed render: " + std::to_string(outside) + " of the result's " + std::to_string(n) +
                      " rest positions lie outside the NeRF's box " + boxText(box) + " (first: particle " +
                      std::to_string(first_outside) + " at " + vec(result.positions[first_outside]) +
                      "); the result belongs to another body or frame");
  }
  const double share = static_cast<double>(occupied) / static_cast<double>(n);
  if (share < config.min_occupied_share) {
    throw core::Error("deformed render: only " + std::to_string(100.0 * share) +
                      " % of the result's rest positions lie where the NeRF has density (need " +
                      std::to_string(100.0 * config.min_occupied_share) +
                      " %); the result was computed on another body");
  }
  return result;
}

/// The scene box: the model's when the deformed body fits in it (so a zero displacement
/// marches exactly the samples of the undeformed renderer), else grown to hold it.
nerf::Box sceneBox(const nerf::NerfModel& model, const TetEmbedding& embedding, int& resolution) {
  nerf::Box box = model.bounds();
  double growth = 1.0;
  for (int a = 0; a < 3; ++a) {
    const double old_size = box.size(a);
    box.min[a] = std::min(box.min[a], static_cast<float>(embedding.deformedMin()[a]));
    box.max[a] = std::max(box.max[a], static_cast<float>(embedding.deformedMax()[a]));
    growth = std::max(growth, box.size(a) / old_size);
  }
  resolution = model.grid().resolution();
  if (growth > 1.0) {
    resolution = std::min(256, static_cast<int>(std::ceil(resolution * growth)));
    resolution += resolution % 2;  // the bitfield holds whole bytes
  }
  return box;
}

/// Rasterises the deformed tetrahedra (boxes grown by the margin) whose rest region touches a
/// cell the NeRF occupies.
void rasterise(const nerf::NerfModel& model, const TetEmbedding& emb, nerf::OccupancyGrid& grid) {
  std::fill(grid.bits().begin(), grid.bits().end(), 0);
  const nerf::OccupancyGrid& rest_grid = model.grid();
  const int r = grid.resolution();
  const nerf::Box& b = grid.bounds();
  const double margin = emb.margin();
  auto cells = [](const nerf::Box& box, int res, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, int* from,
                  int* to) {
    for (int a = 0; a < 3; ++a) {
      from[a] = std::clamp(static_cast<int>(std::floor((lo[a] - box.min[a]) / box.size(a) * res)), 0, res - 1);
      to[a] = std::clamp(static_cast<int>(std::floor((hi[a] - box.min[a]) / box.size(a) * res)), 0, res - 1);
    }
  };
  for (std::size_t t = 0; t < emb.tetCount(); ++t) {
    const auto& v = emb.tet(t);
    Eigen::Vector3d lo = emb.restPositions()[v[0]], hi = lo;
    Eigen::Vector3d dlo = emb.deformedPositions()[v[0]], dhi = dlo;
    for (int k = 1; k < 4; ++k) {
      lo = lo.cwiseMin(emb.restPositions()[v[k]]);
      hi = hi.cwiseMax(emb.restPositions()[v[k]]);
      dlo = dlo.cwiseMin(emb.deformedPositions()[v[k]]);
      dhi = dhi.cwiseMax(emb.deformedPositions()[v[k]]);
    }
    lo.array() -= margin;
    hi.array() += margin;
    const float rest_lo[3] = {float(lo.x()), float(lo.y()), float(lo.z())};
    const float rest_hi[3] = {float(hi.x()), float(hi.y()), float(hi.z())};
    if (!rest_grid.anyOccupied(rest_lo, rest_hi)) continue;
    int from[3], to[3];
    dlo.array() -= margin;
    dhi.array() += margin;
    cells(b, r, dlo, dhi, from, to);
    for (int z = from[2]; z <= to[2]; ++z)
      for (int y = from[1]; y <= to[1]; ++y)
        for (int x = from[0]; x <= to[0]; ++x) {
          const std::int64_t c = (static_cast<std::int64_t>(z) * r + y) * r + x;
          grid.bits()[c >> 3] |= static_cast<std::uint8_t>(1u << (c & 7));
        }
  }
}

}  // namespace

DeformedScene::DeformedScene(const nerf::NerfModel& model, const core::ResultField& result,
                             const DeformedRenderConfig& config)
    : model_(model), config_(config), embedding_(checked(model, result, config), config.embedding) {
  int resolution = 0;
  const nerf::Box box = sceneBox(model, embedding_, resolution);
  nerf::OccupancyConfig oc = model.config().occupancy;
  oc.resolution = resolution;
  // One grid over the deformed body's box: it only needs to hold the body.
  grid_ = nerf::OccupancyGrid(oc, box, model.march().min_step, 1);
  rasterise(model, embedding_, grid_);
  field_ = std::make_unique<DeformedField>(model, embedding_, box, config.rotate_directions);
}

nerf::MarchScene DeformedScene::marchScene() const {
  // The undeformed renderer's marching, so a zero displacement marches the same samples.
  return {model_.renderMarch(), grid_, grid_.bounds(), model_.config().march.samples_per_round};
}

nerf::RenderedImage renderDeformed(const DeformedScene& scene, const core::PinholeCamera& camera,
                                   const Eigen::Isometry3d& world_from_camera, const Eigen::Vector3f& background) {
  return nerf::renderView(scene.field(), scene.marchScene(), camera, world_from_camera, background);
}

nerf::RenderedImage renderDeformed(const DeformedScene& scene, const core::PinholeCamera& camera,
                                   const Eigen::Isometry3d& world_from_camera) {
  const auto& b = scene.model().config().background;
  return renderDeformed(scene, camera, world_from_camera,
                        Eigen::Vector3f(static_cast<float>(b[0]), static_cast<float>(b[1]), static_cast<float>(b[2])));
}

}  // namespace demnerf::render
