#include "demnerf/render/scene_geometry.hpp"

#include <cmath>

#include "demnerf/core/error.hpp"
#include "demnerf/render/box_mesh.hpp"

namespace demnerf::render {

SceneKind parseSceneKind(const std::string& name) {
  if (name == "tbar") return SceneKind::kTBar;
  if (name == "cuboid") return SceneKind::kCuboid;
  if (name == "cook") return SceneKind::kCookMembrane;
  throw core::Error("unknown scene '" + name + "' (known scenes: tbar, cuboid, cook)");
}

const char* sceneName(SceneKind kind) {
  switch (kind) {
    case SceneKind::kTBar: return "tbar";
    case SceneKind::kCuboid: return "cuboid";
    case SceneKind::kCookMembrane: return "cook";
  }
  return "unknown";
}

core::TriangleMesh makeTBarMesh(const TBarDimensions& d, double max_edge) {
  const double top = d.leg_height + d.bar_height;
  const Eigen::AlignedBox3d leg(Eigen::Vector3d(-0.5 * d.leg_width, -0.5 * d.leg_width, 0.0),
                                Eigen::Vector3d(0.5 * d.leg_width, 0.5 * d.leg_width, d.leg_height));
  const Eigen::AlignedBox3d bar(Eigen::Vector3d(-0.5 * d.bar_length, -0.5 * d.bar_width, d.leg_height),
                                Eigen::Vector3d(0.5 * d.bar_length, 0.5 * d.bar_width, top));
  if (d.leg_width > d.bar_length || d.leg_width > d.bar_width) {
    throw core::Error("T-bar: the leg (" + std::to_string(d.leg_width) +
                      " m wide) must not be wider than the bar");
  }
  return meshBoxUnion({leg, bar}, max_edge);
}

core::TriangleMesh makeCuboidMesh(const CuboidDimensions& d, double max_edge) {
  const Eigen::AlignedBox3d box(Eigen::Vector3d(0.0, -0.5 * d.width, -0.5 * d.height),
                                Eigen::Vector3d(d.length, 0.5 * d.width, 0.5 * d.height));
  return meshBoxUnion({box}, max_edge);
}

core::TriangleMesh makeCookMembraneMesh(const CookMembraneDimensions& d, double max_edge) {
  if (!(max_edge > 0) || !(d.thickness > 0)) {
    throw core::Error("Cook's membrane: max_edge and thickness must be positive");
  }
  // Bilinear map of the unit square onto the quadrilateral: s runs from the left edge
  // (corners 0, 3) to the right edge (1, 2), t from the bottom edge (0, 1) to the top (3, 2).
  const Eigen::Vector2d p00 = d.corners[0], p10 = d.corners[1], p11 = d.corners[2], p01 = d.corners[3];
  const double bottom = (p10 - p00).norm(), top = (p11 - p01).norm();
  const double left = (p01 - p00).norm(), right = (p11 - p10).norm();
  StructuredSolid solid;
  solid.cells = {std::max(1, static_cast<int>(std::ceil(std::max(bottom, top) / max_edge))),
                 std::max(1, static_cast<int>(std::ceil(std::max(left, right) / max_edge))), 1};
  const auto cells = solid.cells;
  const double thickness = d.thickness;
  solid.occupied = [](int, int, int) { return true; };
  solid.node = [=](int i, int j, int k) {
    const double s = static_cast<double>(i) / cells[0];
    const double t = static_cast<double>(j) / cells[1];
    const Eigen::Vector2d p = (1 - s) * (1 - t) * p00 + s * (1 - t) * p10 + s * t * p11 + (1 - s) * t * p01;
    return Eigen::Vector3d(p.x(), p.y(), k * thickness);
  };
  core::TriangleMesh mesh = meshStructuredSolid(solid);
  // A clockwise corner order flips the map's orientation and with it every face.
  if (enclosedVolume(mesh) < 0) {
    for (auto& f : mesh.faces) std::swap(f[1], f[2]);
  }
  return mesh;
}

SceneObject makeSceneObject(SceneKind kind, double max_edge) {
  SceneObject object;
  object.kind = kind;
  switch (kind) {
    case SceneKind::kTBar: {
      const TBarDimensions d;
      object.mesh = makeTBarMesh(d, max_edge > 0 ? max_edge : 0.005);
      object.base_color = {0.90, 0.62, 0.30};  // an orange rubber
      break;
    }
    case SceneKind::kCuboid: {
      const CuboidDimensions d;
      object.mesh = makeCuboidMesh(d, max_edge > 0 ? max_edge : 0.0025);
      object.base_color = {0.35, 0.62, 0.88};  // a blue foam
      break;
    }
    case SceneKind::kCookMembrane: {
      const CookMembraneDimensions d;
      object.mesh = makeCookMembraneMesh(d, max_edge > 0 ? max_edge : 0.0012);
      object.base_color = {0.45, 0.80, 0.45};  // a green sheet
      break;
    }
  }
  object.bounds.setEmpty();
  for (const auto& v : object.mesh.vertices) object.bounds.extend(v);
  // About 25 speckle cells along the object's diagonal: blobs a few pixels wide at 200 px.
  object.speckle_cell = object.bounds.diagonal().norm() / 25.0;
  return object;
}

}  // namespace demnerf::render
