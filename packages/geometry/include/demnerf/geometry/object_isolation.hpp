#pragma once
// Isolating one object of a real capture (the fox on its table) before meshing: the density is
// sampled inside a user's box in the scene's frame, closed at the box's faces, and only its
// largest connected piece is meshed. Each way this can go wrong is refused with a message that
// says what to change: the box holds no density, it holds several comparable pieces, or the
// surface comes out open.

#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "demnerf/geometry/density_grid.hpp"
#include "demnerf/geometry/density_inside_test.hpp"
#include "demnerf/geometry/mesh_from_density.hpp"

namespace demnerf::geometry {

struct IsolationConfig {
  /// Pieces are 6-connected runs of inside nodes. The largest is kept and smaller ones
  /// (floaters, a sliver of table) are dropped, unless the second largest holds at least this
  /// fraction of the largest's nodes: then the box takes in two objects and we refuse, since
  /// guessing which one the user meant would silently simulate the wrong body.
  double max_second_piece_fraction = 0.2;
};

struct IsolationReport {
  std::size_t pieces = 0;               ///< connected pieces inside the box before dropping
  std::vector<std::size_t> piece_nodes;  ///< their sizes in grid nodes, largest first
  std::size_t nodes_dropped = 0;         ///< inside nodes of the dropped pieces
  double peak = 0.0;                     ///< largest value of the field the surface is cut from
};

/// The finite numbers of a comma-separated list ("1.5,-2,0"); nullopt when an item is not a whole
/// number or is not finite (the CLI's --box and --solid-behind).
std::optional<std::vector<double>> parseNumberList(const std::string& text);

/// Parses "xmin,ymin,zmin,xmax,ymax,zmax" (the CLI's --box). Throws core::Error naming the
/// text unless it has six finite numbers with min < max on every axis.
Eigen::AlignedBox3d parseBox(const std::string& text);

/// "xmin,ymin,zmin,xmax,ymax,zmax" with the box's numbers (for messages and reports).
std::string formatBox(const Eigen::AlignedBox3d& box);

/// The same grid with its outermost layer of nodes set to zero density: whatever the box cuts
/// through (the fox's feet on the table) is capped flat there, so the surface is closed.
DensityGrid closeAtBorder(const DensityGrid& grid);

/// The density on cubic cells over `box` (resolution cells along its longest side), closed at
/// the box's faces.
DensityGrid sampleDensityInBox(const DensityFunction& density, const Eigen::AlignedBox3d& box, int resolution);

/// Throws core::Error (with the counts of open, non-manifold and misoriented edges) unless the
/// mesh is closed. A grid closed at the box's faces always gives a closed surface; an open one
/// comes from density running out of the grid (walls of a scene meshed without a box).
void requireClosedIsolation(const core::TriangleMesh& mesh);

/// Meshes the largest piece of the body in `boxed` (a grid over the user's box, as
/// sampleDensityInBox gives). Throws core::Error when no node reaches the surface level (box
/// empty), when the box holds several comparable pieces (with their count and sizes), or when
/// the repaired surface is still open.
MeshExtractionResult isolateObject(const DensityGrid& boxed, const MeshExtractionConfig& extraction,
                                   const IsolationConfig& isolation = {}, IsolationReport* report = nullptr);

}  // namespace demnerf::geometry
