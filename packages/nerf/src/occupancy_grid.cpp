#include "demnerf/nerf/occupancy_grid.hpp"

#include <algorithm>
#include <numeric>
#include <random>

namespace demnerf::nerf {

OccupancyGrid::OccupancyGrid(const OccupancyConfig& config, const Box& bounds, float min_step)
    : config_(config), bounds_(bounds), min_step_(min_step), resolution_(config.resolution) {
  thickness_.assign(cells(), 0.0f);
  bits_.assign(cells() / 8, 0);
  markAll();
}

void OccupancyGrid::markAll() { std::fill(bits_.begin(), bits_.end(), 0xff); }

std::int64_t OccupancyGrid::cellOf(const float* p) const {
  int c[3];
  for (int a = 0; a < 3; ++a) {
    const float u = (p[a] - bounds_.min[a]) / bounds_.size(a);
    if (!(u >= 0.0f && u <= 1.0f)) return -1;
    c[a] = std::min(static_cast<int>(u * resolution_), resolution_ - 1);
  }
  return (static_cast<std::int64_t>(c[2]) * resolution_ + c[1]) * resolution_ + c[0];
}

double OccupancyGrid::occupiedFraction() const {
  std::int64_t count = 0;
  for (std::uint8_t b : bits_) count += __builtin_popcount(b);
  return cells() ? static_cast<double>(count) / static_cast<double>(cells()) : 0.0;
}

void OccupancyGrid::sampleCells(const Field& field, const std::vector<std::int64_t>& cells, std::uint64_t seed,
                                std::vector<float>& best) const {
  std::vector<float> points(3 * cells.size()), sigma(cells.size());
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  const int r = resolution_;
  for (std::size_t i = 0; i < cells.size(); ++i) {
    const std::int64_t c = cells[i];
    const std::int64_t idx[3] = {c % r, (c / r) % r, c / (static_cast<std::int64_t>(r) * r)};
    for (int a = 0; a < 3; ++a) {
      points[3 * i + a] = bounds_.min[a] + (static_cast<float>(idx[a]) + unit(rng)) / r * bounds_.size(a);
    }
  }
  field.density(points.data(), static_cast<std::int64_t>(cells.size()), sigma.data());
  for (std::size_t i = 0; i < cells.size(); ++i) best[cells[i]] = std::max(best[cells[i]], sigma[i] * min_step_);
}

void OccupancyGrid::update(const Field& field, std::int64_t step, std::uint64_t seed) {
  const std::int64_t n = cells();
  std::vector<std::int64_t> chosen;
  std::mt19937_64 rng(seed ^ (0x9e3779b97f4a7c15ull * static_cast<std::uint64_t>(step + 1)));
  if (step < config_.warmup_steps) {
    chosen.resize(n);
    std::iota(chosen.begin(), chosen.end(), 0);
  } else {
    std::uniform_int_distribution<std::int64_t> any(0, n - 1);
    for (std::int64_t i = 0; i < n / 4; ++i) chosen.push_back(any(rng));
    std::vector<std::int64_t> occupied_cells;
    for (std::int64_t c = 0; c < n; ++c) if (occupied(c)) occupied_cells.push_back(c);
    if (!occupied_cells.empty()) {
      std::uniform_int_distribution<std::size_t> pick(0, occupied_cells.size() - 1);
      for (std::int64_t i = 0; i < n / 4; ++i) chosen.push_back(occupied_cells[pick(rng)]);
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
  std::vector<std::int64_t> all(cells());
  std::iota(all.begin(), all.end(), 0);
  std::vector<float> best(cells(), 0.0f);
  for (int s = 0; s < samples_per_cell; ++s) sampleCells(field, all, seed + s, best);
  thickness_ = best;
  refreshBits();
}

void OccupancyGrid::refreshBits() {
  const double mean = std::accumulate(thickness_.begin(), thickness_.end(), 0.0) / static_cast<double>(cells());
  const float threshold = static_cast<float>(std::min(config_.threshold, mean));
  std::fill(bits_.begin(), bits_.end(), 0);
  for (std::int64_t c = 0; c < cells(); ++c) {
    if (thickness_[c] > threshold) bits_[c >> 3] |= static_cast<std::uint8_t>(1u << (c & 7));
  }
}

}  // namespace demnerf::nerf
