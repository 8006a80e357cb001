#include "demnerf/nerf/occupancy_grid.hpp"

#include <ATen/Parallel.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>

namespace demnerf::nerf {

int cascadeCount(const OccupancyConfig& config, double aabb_scale) {
  if (config.cascades > 0) return config.cascades;
  int count = 1;
  while (count < 8 && static_cast<double>(1 << (count - 1)) < aabb_scale - 1e-9) ++count;
  return count;
}

OccupancyGrid::OccupancyGrid(const OccupancyConfig& config, const Box& bounds, float min_step, int cascades)
    : config_(config), bounds_(bounds), min_step_(min_step), resolution_(config.resolution),
      cascades_(std::max(1, cascades)) {
  const float shrink = 1.0f / static_cast<float>(1 << (cascades_ - 1));
  min_cell_ = bounds.size(0);
  for (int a = 0; a < 3; ++a) {
    centre_[a] = 0.5f * (bounds.min[a] + bounds.max[a]);
    half_[a] = 0.5f * bounds.size(a);
    min_cell_ = std::min(min_cell_, bounds.size(a) * shrink / resolution_);
  }
  thickness_.assign(cells(), 0.0f);
  bits_.assign(cells() / 8, 0);
  markCovered();
  markAll();
}

Box OccupancyGrid::cascadeBox(int k) const {
  const float scale = 1.0f / static_cast<float>(1 << (cascades_ - 1 - k));
  Box box;
  for (int a = 0; a < 3; ++a) {
    box.min[a] = centre_[a] - half_[a] * scale;
    box.max[a] = centre_[a] + half_[a] * scale;
  }
  return box;
}

void OccupancyGrid::markCovered() {
  // A cell of cascade k > 0 is covered when its centre lies in cascade k - 1 (the cascades
  // nest on cell boundaries, since the resolution is even).
  used_.assign(cells(), 1);
  const std::int64_t per = cellsPerCascade();
  for (int k = 1; k < cascades_; ++k) {
    const Box inner = cascadeBox(k - 1);
    for (std::int64_t c = 0; c < per; ++c) {
      float p[3];
      cellCentre(k * per + c, p);
      bool inside = true;
      for (int a = 0; a < 3; ++a) inside &= p[a] > inner.min[a] && p[a] < inner.max[a];
      if (inside) used_[k * per + c] = 0;
    }
  }
}

void OccupancyGrid::markAll() {
  std::fill(bits_.begin(), bits_.end(), 0);
  for (std::int64_t c = 0; c < cells(); ++c) {
    if (used_[c]) bits_[c >> 3] |= static_cast<std::uint8_t>(1u << (c & 7));
  }
}

int OccupancyGrid::cascadeOf(const float* p) const {
  float m = 0.0f;
  for (int a = 0; a < 3; ++a) m = std::max(m, std::fabs(p[a] - centre_[a]) / half_[a]);
  if (!(m <= 1.0f)) return -1;
  int k = 0;
  float limit = 1.0f / static_cast<float>(1 << (cascades_ - 1));
  while (k < cascades_ - 1 && m > limit) {
    limit *= 2.0f;
    ++k;
  }
  return k;
}

std::int64_t OccupancyGrid::cellOf(const float* p) const {
  const int k = cascadeOf(p);
  if (k < 0) return -1;
  const float scale = static_cast<float>(1 << (cascades_ - 1 - k));
  int c[3];
  for (int a = 0; a < 3; ++a) {
    // Position in cascade k's box, in [0, 1].
    const float u = 0.5f + (p[a] - centre_[a]) * scale / (2.0f * half_[a]);
    c[a] = std::clamp(static_cast<int>(u * resolution_), 0, resolution_ - 1);
  }
  return k * cellsPerCascade() + (static_cast<std::int64_t>(c[2]) * resolution_ + c[1]) * resolution_ + c[0];
}

void OccupancyGrid::cellCentre(std::int64_t cell, float* centre) const {
  const std::int64_t per = cellsPerCascade();
  const int k = static_cast<int>(cell / per);
  const std::int64_t local = cell % per, r = resolution_;
  const std::int64_t idx[3] = {local % r, (local / r) % r, local / (r * r)};
  const Box box = cascadeBox(k);
  for (int a = 0; a < 3; ++a) centre[a] = box.min[a] + (static_cast<float>(idx[a]) + 0.5f) / r * box.size(a);
}

float OccupancyGrid::cellExit(int k, const float* p, const float* origin, const float* inv_dir) const {
  const Box box = cascadeBox(k);
  float t_exit = std::numeric_limits<float>::max();
  for (int a = 0; a < 3; ++a) {
    if (!std::isfinite(inv_dir[a])) continue;
    const float size = box.size(a) / resolution_;
    const float u = (p[a] - box.min[a]) / size;
    const float index = std::floor(std::min(std::max(u, 0.0f), static_cast<float>(resolution_) - 1e-3f));
    const float boundary = box.min[a] + (inv_dir[a] > 0 ? index + 1.0f : index) * size;
    t_exit = std::min(t_exit, (boundary - origin[a]) * inv_dir[a]);
  }
  return t_exit;
}

bool OccupancyGrid::anyOccupied(const float* lo, const float* hi) const {
  const int r = resolution_;
  for (int k = 0; k < cascades_; ++k) {
    const Box box = cascadeBox(k);
    int from[3], to[3];
    bool overlaps = true;
    for (int a = 0; a < 3; ++a) {
      overlaps &= hi[a] >= box.min[a] && lo[a] <= box.max[a];
      from[a] = std::clamp(static_cast<int>(std::floor((lo[a] - box.min[a]) / box.size(a) * r)), 0, r - 1);
      to[a] = std::clamp(static_cast<int>(std::floor((hi[a] - box.min[a]) / box.size(a) * r)), 0, r - 1);
    }
    if (!overlaps) continue;
    const std::int64_t base = k * cellsPerCascade();
    for (int z = from[2]; z <= to[2]; ++z)
      for (int y = from[1]; y <= to[1]; ++y)
        for (int x = from[0]; x <= to[0]; ++x)
          if (occupied(base + (static_cast<std::int64_t>(z) * r + y) * r + x)) return true;
  }
  return false;
}

double OccupancyGrid::occupiedFraction() const {
  std::int64_t count = 0, used = 0;
  for (std::uint8_t b : bits_) count += __builtin_popcount(b);
  for (std::uint8_t u : used_) used += u;
  return used ? static_cast<double>(count) / static_cast<double>(used) : 0.0;
}

void OccupancyGrid::sampleCells(const Field& field, const std::vector<std::int64_t>& cells, std::uint64_t seed,
                                std::vector<float>& best) const {
  std::vector<float> points(3 * cells.size()), sigma(cells.size());
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> unit(-0.5f, 0.5f);
  for (std::size_t i = 0; i < cells.size(); ++i) {
    float* p = points.data() + 3 * i;
    cellCentre(cells[i], p);
    const Box box = cascadeBox(static_cast<int>(cells[i] / cellsPerCascade()));
    for (int a = 0; a < 3; ++a) p[a] += unit(rng) * box.size(a) / resolution_;
  }
  field.density(points.data(), static_cast<std::int64_t>(cells.size()), sigma.data());
  for (std::size_t i = 0; i < cells.size(); ++i) best[cells[i]] = std::max(best[cells[i]], sigma[i] * min_step_);
}

void OccupancyGrid::update(const Field& field, std::int64_t step, std::uint64_t seed) {
  const std::int64_t n = cells();
  std::vector<std::int64_t> chosen;
  std::mt19937_64 rng(seed ^ (0x9e3779b97f4a7c15ull * static_cast<std::uint64_t>(step + 1)));
  if (step < config_.warmup_steps) {
    for (std::int64_t c = 0; c < n; ++c) if (used_[c]) chosen.push_back(c);
  } else {
    std::vector<std::int64_t> occupied_cells;
    std::int64_t used = 0;
    for (std::int64_t c = 0; c < n; ++c) {
      used += used_[c];
      if (occupied(c)) occupied_cells.push_back(c);
    }
    std::uniform_int_distribution<std::int64_t> any(0, n - 1);
    for (std::int64_t i = 0; i < n / 4; ++i) {
      const std::int64_t c = any(rng);
      if (used_[c]) chosen.push_back(c);  // unseen and covered cells stay empty: no query
    }
    if (!occupied_cells.empty()) {
      std::uniform_int_distribution<std::size_t> pick(0, occupied_cells.size() - 1);
      for (std::int64_t i = 0; i < used / 4; ++i) chosen.push_back(occupied_cells[pick(rng)]);
    }
  }
  std::vector<float> best(n, -1.0f);
  sampleCells(field, chosen, rng(), best);
  const float decay = static_cast<float>(config_.decay);
  for (std::int64_t c = 0; c < n; ++c) {
    if (best[c] >= 0.0f) thickness_[c] = std::max(thickness_[c] * decay, best[c]);
  }
  refreshBits();
}

void OccupancyGrid::rebuild(const Field& field, int samples_per_cell, std::uint64_t seed) {
  std::vector<std::int64_t> all;
  for (std::int64_t c = 0; c < cells(); ++c) if (used_[c]) all.push_back(c);
  std::vector<float> best(cells(), 0.0f);
  for (int s = 0; s < samples_per_cell; ++s) sampleCells(field, all, seed + s, best);
  thickness_ = best;
  refreshBits();
}

void OccupancyGrid::refreshBits() {
  double sum = 0.0;
  std::int64_t used = 0;
  for (std::int64_t c = 0; c < cells(); ++c) {
    if (!used_[c]) continue;
    sum += thickness_[c];
    ++used;
  }
  const double mean = used ? sum / static_cast<double>(used) : 0.0;
  const float threshold = static_cast<float>(std::min(config_.threshold, mean));
  std::fill(bits_.begin(), bits_.end(), 0);
  for (std::int64_t c = 0; c < cells(); ++c) {
    if (used_[c] && thickness_[c] > threshold) bits_[c >> 3] |= static_cast<std::uint8_t>(1u << (c & 7));
  }
}

void OccupancyGrid::setVisibility(const std::vector<GridCamera>& cameras) {
  const std::vector<std::uint8_t> before = used_;
  markCovered();
  const std::int64_t per = cellsPerCascade();
  const bool cull = config_.cull_unseen && !cameras.empty();
  at::parallel_for(0, cull ? cells() : 0, 4096, [&](std::int64_t begin, std::int64_t end) {
    for (std::int64_t c = begin; c < end; ++c) {
      if (!used_[c]) continue;
      float p[3];
      cellCentre(c, p);
      const Box box = cascadeBox(static_cast<int>(c / per));
      float radius = 0.0f;
      for (int a = 0; a < 3; ++a) radius += 0.25f * (box.size(a) / resolution_) * (box.size(a) / resolution_);
      radius = std::sqrt(radius);
      bool seen = false;
      for (const GridCamera& cam : cameras) {
        const float d[3] = {p[0] - cam.origin[0], p[1] - cam.origin[1], p[2] - cam.origin[2]};
        const float* r = cam.rotation;
        const float z = r[2] * d[0] + r[5] * d[1] + r[8] * d[2];
        if (z < -radius) continue;
        if (z <= radius) {  // the cell straddles the image plane: count it seen
          seen = true;
          break;
        }
        const float x = r[0] * d[0] + r[3] * d[1] + r[6] * d[2];
        const float y = r[1] * d[0] + r[4] * d[1] + r[7] * d[2];
        const float u = cam.fx * x / z + cam.cx, v = cam.fy * y / z + cam.cy;
        const float mu = cam.fx * radius / z, mv = cam.fy * radius / z;
        if (u >= -mu && u <= cam.width + mu && v >= -mv && v <= cam.height + mv) {
          seen = true;
          break;
        }
      }
      if (!seen) used_[c] = 0;
    }
  });
  // Cells a new camera brings into view start occupied, with a thickness that lets them be
  // sampled a few times before the decay can drop them.
  const float fresh = static_cast<float>(2.0 * config_.threshold + 1e-3);
  for (std::int64_t c = 0; c < cells(); ++c) {
    const std::uint8_t mask = static_cast<std::uint8_t>(1u << (c & 7));
    if (!used_[c]) {
      thickness_[c] = 0.0f;
      bits_[c >> 3] &= static_cast<std::uint8_t>(~mask);
    } else if (!before[c]) {
      thickness_[c] = std::max(thickness_[c], fresh);
      bits_[c >> 3] |= mask;
    }
  }
}

}  // namespace demnerf::nerf
