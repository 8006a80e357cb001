#include <algorithm>
#include <cmath>
#include <numeric>

#include "sampling_internal.hpp"

namespace demnerf::geometry::detail {

SampleSet samplePoisson(const PreparedMesh& prepared, const SamplerConfig& config, Rng& rng) {
  // Bridson's algorithm in 3D: grow the set from active particles by trying k candidates in the
  // shell [r, 2r] around one, keeping a candidate that is inside and at least r from all
  // others. The surface particles (Poisson disk on the mesh) seed the front, so the whole cloud,
  // surface and interior, keeps the minimum distance r and the boundary layer is dense.
  const double r = config.spacing;
  SampleSet set;
  if (config.surface) sampleSurfacePoisson(prepared, r, rng, &set);

  Eigen::AlignedBox3d box = prepared.bounds();
  PointGrid grid(box, r);
  std::vector<Eigen::Vector3d> active;
  for (const auto& p : set.surface) {
    grid.insert(p);
    active.push_back(p);
  }
  // Fallback seeds: grid nodes at spacing r inside the body, visited in random order. Any
  // region the front cannot reach (a part connected through a neck thinner than r) or a body
  // without surface seeds still gets filled.
  const GridLayout layout = gridLayout(box.min(), box.max(), r);
  const Lattice lattice = layoutLattice(layout);
  const std::vector<std::uint8_t> inside_nodes = classifyLattice(prepared.mesh, lattice);
  std::vector<std::size_t> seeds;
  for (std::size_t i = 0; i < inside_nodes.size(); ++i) {
    if (inside_nodes[i]) seeds.push_back(i);
  }
  std::shuffle(seeds.begin(), seeds.end(), rng);
  std::size_t next_seed = 0;

  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::normal_distribution<double> gaussian(0.0, 1.0);
  const int attempts = std::max(1, config.poisson_attempts);
  const std::size_t limit = config.max_particles;
  auto tryAdd = [&](const Eigen::Vector3d& c) {
    if (!box.contains(c) || grid.anyWithin(c, r) || !prepared.inside.inside(c)) return false;
    grid.insert(c);
    active.push_back(c);
    set.interior.push_back(c);
    return true;
  };
  while (set.interior.size() + set.surface.size() < limit) {
    if (active.empty()) {
      bool seeded = false;
      while (!seeded && next_seed < seeds.size()) {
        const std::size_t s = seeds[next_seed++];
        const int i = static_cast<int>(s % layout.dims.x());
        const int j = static_cast<int>((s / layout.dims.x()) % layout.dims.y());
        const int k = static_cast<int>(s / (static_cast<std::size_t>(layout.dims.x()) * layout.dims.y()));
        seeded = tryAdd(lattice.node(i, j, k));
      }
      if (!seeded) break;
    }
    const std::size_t pick = static_cast<std::size_t>(uniform(rng) * active.size()) % active.size();
    const Eigen::Vector3d centre = active[pick];
    bool placed = false;
    for (int attempt = 0; attempt < attempts && !placed; ++attempt) {
      Eigen::Vector3d direction(gaussian(rng), gaussian(rng), gaussian(rng));
      const double norm = direction.norm();
      if (norm == 0.0) continue;
      // Uniform in the shell's volume: r^3 <= radius^3 <= 8 r^3.
      const double radius = r * std::cbrt(1.0 + 7.0 * uniform(rng));
      placed = tryAdd(centre + direction * (radius / norm));
    }
    if (!placed) {
      active[pick] = active.back();
      active.pop_back();
    }
  }
  return set;
}

}  // namespace demnerf::geometry::detail
