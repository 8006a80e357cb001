#pragma once
// Making a NeRF's occupied region solid before its surface is taken. A NeRF only needs density
// where rays stop (and nerf_fox.yaml's prior pushes it down behind them), so what a density level
// cuts out of a real capture is its visible surface: the fox's head is a shell 2-4 cells thick,
// holed (genus ~450) and open at the back no camera saw, and most particles sampled in it land on
// its surface. Three steps, each for one of these: a morphological closing (dilate the inside by
// a ball of radius r, then erode the result by the same ball) shuts tunnels and gaps narrower
// than about 2r while convex parts of the outline stay where they were; a fill of what the
// cameras of a one-sided capture never saw as empty (space carving against the capture's own
// cameras, or, coarser, everything behind the body along one direction) closes the back; and a
// flood of the empty nodes from the grid's border fills whatever is then sealed off inside.

#include <Eigen/Core>
#include <cstddef>
#include <vector>

#include "demnerf/core/ply.hpp"
#include "demnerf/geometry/density_grid.hpp"
#include "demnerf/geometry/visual_hull.hpp"

namespace demnerf::geometry {

struct SolidConfig {
  /// The closing's radius in the scene's units (0: none). Shuts tunnels and gaps narrower than
  /// about twice it; convex parts of the outline stay where they were.
  double radius = 0.0;
  /// Non-zero: the direction from the body towards the cameras of a capture that saw it from one
  /// side only (the fox on its wall). Every node the inside hides from that side, i.e. whose ray
  /// along it meets the inside before leaving the grid, is filled: space no camera could see
  /// into counts as body, up to the box's far face. Zero: no such fill (captures seen all round).
  Eigen::Vector3d behind = Eigen::Vector3d::Zero();
  /// Non-empty: the capture's (training) cameras. Every node that no camera saw as empty (in its
  /// image, with nothing of the closed body between them: unseenByCameras) is filled, so the back
  /// of a head seen from the front is filled and the space beside it an oblique camera saw is
  /// not. Tighter than `behind`, which it excludes. The carved fill is closed once more with
  /// `radius`, which shuts the slits grazing views leave where it meets the closed body.
  std::vector<ViewCamera> cameras;
  /// With cameras: how many must see a node in plain view before it counts as empty (1: the
  /// visual hull; the fox takes 4 so its thin ears, seen edge-on, keep a back).
  int min_views = 1;
  bool enabled() const { return radius != 0.0 || behind != Eigen::Vector3d::Zero() || !cameras.empty(); }
};

struct SolidReport {
  double radius_cells = 0.0;       ///< the closing's radius in grid cells (the largest spacing's)
  std::size_t closed_nodes = 0;    ///< outside nodes the closing made inside (tunnels, gaps, dents)
  std::size_t hidden_nodes = 0;    ///< outside nodes hidden behind the inside (behind, or cameras)
  std::size_t unseen_nodes = 0;    ///< with cameras: outside nodes in no camera's image (filled too)
  std::size_t cavity_nodes = 0;    ///< outside nodes no path of outside nodes joins to the border
};

/// The field with its inside ({value > level}) made solid: a closing by a Euclidean ball of
/// config.radius, then the fill of what the inside hides from config.behind or from every one of
/// config.cameras that has the node in its image (nodes in none count as hidden), then every outside
/// node not 6-connected to the grid's border through outside nodes is filled. Nodes made inside
/// get max(value, 2 level) (level + 1 for level <= 0), which puts the new surface half-way
/// between them and their outside neighbours; other nodes keep their values, so surfaces the
/// solid leaves alone do not move. Beyond the grid counts as neither inside nor outside: a body
/// the box cuts is not eroded from the cut, and the grid's outermost layer of nodes is never
/// filled (the cut's cap stays put). Throws core::Error for a negative or non-finite radius,
/// a non-finite direction, both a direction and cameras, or a camera unusable for carving.
DensityGrid solidifyField(const DensityGrid& field, double level, const SolidConfig& config,
                          SolidReport* report = nullptr);

/// Squared Euclidean distance (scene units) from each node to the nearest node where `feature`
/// is true, over the grid only; a huge value (> 1e29) where there is none. Exact (separable lower
/// envelopes of parabolas, one pass per axis), O(nodes).
std::vector<double> squaredDistanceTo(const DensityGrid& grid, const std::vector<char>& feature);

/// What kind of closed surface a mesh is: V - E + F and the handles it implies.
struct SurfaceTopology {
  std::size_t components = 0;  ///< pieces connected through shared vertices
  long long euler = 0;         ///< V - E + F over the vertices faces use
  long long genus = 0;         ///< handles in total, components - euler / 2 (a closed surface's)
};

/// Counts the mesh's components, Euler characteristic and genus (a sphere: 1, 2, 0; a torus:
/// 1, 0, 1). The genus is meaningful for closed meshes, which extraction gives.
SurfaceTopology surfaceTopology(const core::TriangleMesh& mesh);

}  // namespace demnerf::geometry
