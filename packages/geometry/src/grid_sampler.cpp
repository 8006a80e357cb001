#include "sampling_internal.hpp"

namespace demnerf::geometry::detail {

SampleSet sampleGrid(const PreparedMesh& prepared, const SamplerConfig& config, Rng&) {
  // The paper's Eq. (uniformedMeshSample): nodes a fixed distance h apart on each axis; those
  // inside the body are the particles, found by scanlines along x.
  const GridLayout layout = gridLayout(prepared.bounds().min(), prepared.bounds().max(), config.spacing);
  const Lattice lattice = layoutLattice(layout);
  const std::vector<std::uint8_t> inside = classifyLattice(prepared.mesh, lattice);
  SampleSet set;
  for (int k = 0; k < lattice.dims.z(); ++k) {
    for (int j = 0; j < lattice.dims.y(); ++j) {
      for (int i = 0; i < lattice.dims.x(); ++i) {
        if (inside[lattice.index(i, j, k)]) set.interior.push_back(lattice.node(i, j, k));
      }
    }
  }
  if (config.surface) sampleSurfaceGrid(prepared, layout, &set);
  return set;
}

}  // namespace demnerf::geometry::detail
