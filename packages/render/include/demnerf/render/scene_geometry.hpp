#pragma once
// The synthetic test objects (T-bar, cuboid, Cook's membrane) as exact closed meshes in metres.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>

#include "demnerf/core/ply.hpp"

namespace demnerf::render {

enum class SceneKind { kTBar, kCuboid, kCookMembrane };

/// "tbar", "cuboid" or "cook"; throws core::Error listing the known names otherwise.
SceneKind parseSceneKind(const std::string& name);
const char* sceneName(SceneKind kind);

/// Dimensions (metres). The T-bar: a vertical leg along +z from z = 0 to leg_height, centred on
/// x = y = 0, with the horizontal bar along x on top of it.
struct TBarDimensions {
  double bar_length = 0.30;   ///< x
  double bar_width = 0.06;    ///< y
  double bar_height = 0.06;   ///< z
  double leg_width = 0.06;    ///< x and y
  double leg_height = 0.24;   ///< z
};

/// The cuboid of the DEM literature (1.25 x 1 x 1) scaled to 0.125 x 0.1 x 0.1 m: x from 0 to
/// length, centred on y = z = 0, so the twist axis is the x axis.
struct CuboidDimensions {
  double length = 0.125;
  double width = 0.1;
  double height = 0.1;
};

/// Cook's membrane: the quadrilateral (0,0), (48,44), (48,60), (0,44) mm in the xy plane,
/// extruded from z = 0 to z = thickness (1 mm).
struct CookMembraneDimensions {
  Eigen::Vector2d corners[4] = {{0.0, 0.0}, {0.048, 0.044}, {0.048, 0.060}, {0.0, 0.044}};
  double thickness = 0.001;
};

/// A synthetic object: its exact surface and the look of its surface.
struct SceneObject {
  SceneKind kind = SceneKind::kTBar;
  core::TriangleMesh mesh;            ///< closed, outward-oriented, finely subdivided
  Eigen::AlignedBox3d bounds;         ///< of the mesh
  Eigen::Vector3d base_color{0.8, 0.6, 0.4};  ///< albedo before speckle and orientation tint
  double speckle_cell = 0.01;         ///< speckle lattice spacing (m), scaled to the object
};

core::TriangleMesh makeTBarMesh(const TBarDimensions& dimensions, double max_edge);
core::TriangleMesh makeCuboidMesh(const CuboidDimensions& dimensions, double max_edge);
/// `max_edge` applies in the plane; through the thickness there is one cell (a thin slab).
core::TriangleMesh makeCookMembraneMesh(const CookMembraneDimensions& dimensions, double max_edge);

/// The scene's object with default dimensions. `max_edge` <= 0 picks a default that bends
/// smoothly (about 1/60 of the object's largest extent).
SceneObject makeSceneObject(SceneKind kind, double max_edge = 0.0);

}  // namespace demnerf::render
