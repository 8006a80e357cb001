#include <algorithm>
#include <cmath>

#include "sampling_internal.hpp"

namespace demnerf::geometry::detail {

void sampleSurfaceRandom(const PreparedMesh& prepared, std::size_t count, Rng& rng, SampleSet* set) {
  for (std::size_t i = 0; i < count; ++i) {
    int face = 0;
    set->surface.push_back(prepared.randomSurfacePoint(rng, &face));
    set->surface_faces.push_back(face);
    set->surface_areas.push_back(prepared.area() / static_cast<double>(count));
  }
}

void sampleSurfacePoisson(const PreparedMesh& prepared, double radius, Rng& rng, SampleSet* set) {
  // Dart throwing from a dense pool of uniform surface points: accept a point when no accepted
  // one lies within `radius` (straight-line distance, so sides of thin parts also keep apart).
  // With ~30 pool points per disk the result is close to maximal.
  const std::size_t pool = static_cast<std::size_t>(std::ceil(30.0 * prepared.area() / (radius * radius))) + 100;
  PointGrid grid(prepared.bounds(), radius);
  for (std::size_t s = 0; s < pool; ++s) {
    int face = 0;
    const Eigen::Vector3d p = prepared.randomSurfacePoint(rng, &face);
    if (grid.anyWithin(p, radius)) continue;
    grid.insert(p);
    set->surface.push_back(p);
    set->surface_faces.push_back(face);
    set->surface_areas.push_back(1.0);  // replaced by Voronoi areas
  }
}

void sampleSurfaceGrid(const PreparedMesh& prepared, const GridLayout& layout, SampleSet* set) {
  // Where the grid's lines cross the surface. A crossing along axis a stands for the patch
  // whose projection onto the plane normal to a is one grid cell, h^2 / |n_a|. Each face is
  // sampled only by lines along its dominant normal axis, so patches are not counted twice and
  // |n_a| >= 1/sqrt(3) keeps the weights bounded.
  const Lattice lattice = layoutLattice(layout);
  const double cell_area = layout.spacing * layout.spacing;
  for (int axis = 0; axis < 3; ++axis) {
    const auto lines = latticeLineCrossings(prepared.mesh, lattice, axis);
    const int u_axis = (axis + 1) % 3, v_axis = (axis + 2) % 3;
    const int nu = lattice.dims[u_axis];
    for (std::size_t line = 0; line < lines.size(); ++line) {
      const int a = static_cast<int>(line % nu), b = static_cast<int>(line / nu);
      for (const LineCrossing& crossing : lines[line]) {
        const Eigen::Vector3d& n = prepared.normals[crossing.face];
        int dominant = 0;
        n.cwiseAbs().maxCoeff(&dominant);
        if (dominant != axis) continue;
        Eigen::Vector3d p;
        p[axis] = crossing.position;
        p[u_axis] = lattice.origin[u_axis] + a * lattice.spacing[u_axis];
        p[v_axis] = lattice.origin[v_axis] + b * lattice.spacing[v_axis];
        set->surface.push_back(p);
        set->surface_faces.push_back(crossing.face);
        set->surface_areas.push_back(cell_area / std::abs(n[axis]));
      }
    }
  }
}

}  // namespace demnerf::geometry::detail
