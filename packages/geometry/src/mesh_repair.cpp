#include "demnerf/geometry/mesh_repair.hpp"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/connected_components.h>
#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/orientation.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/repair_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>
#include <CGAL/Surface_mesh.h>

#include <unordered_set>

#include "demnerf/core/error.hpp"
#include "demnerf/geometry/mesh_analysis.hpp"

namespace demnerf::geometry {
namespace {

namespace PMP = CGAL::Polygon_mesh_processing;
using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using SurfaceMesh = CGAL::Surface_mesh<Point>;

core::TriangleMesh toTriangleMesh(const SurfaceMesh& surface) {
  core::TriangleMesh mesh;
  std::vector<int> index(surface.number_of_vertices() + surface.number_of_removed_vertices(), -1);
  for (const auto v : surface.vertices()) {
    index[v.idx()] = static_cast<int>(mesh.vertices.size());
    const Point& p = surface.point(v);
    mesh.vertices.emplace_back(p.x(), p.y(), p.z());
  }
  for (const auto f : surface.faces()) {
    std::array<int, 3> face{};
    int corner = 0;
    for (const auto v : CGAL::vertices_around_face(surface.halfedge(f), surface)) {
      if (corner < 3) face[corner] = index[v.idx()];
      ++corner;
    }
    if (corner == 3) mesh.faces.push_back(face);
  }
  return mesh;
}

}  // namespace

core::TriangleMesh repairMesh(const core::TriangleMesh& mesh, const MeshRepairConfig& config, MeshRepairReport* report) {
  MeshRepairReport local;
  MeshRepairReport& out = report ? *report : local;
  out = MeshRepairReport{};
  if (mesh.faces.empty()) throw core::Error("repairMesh: the mesh has no faces");
  analyzeMesh(mesh);  // throws on bad indices and NaN vertices

  std::vector<Point> points;
  points.reserve(mesh.vertices.size());
  for (const auto& v : mesh.vertices) points.emplace_back(v.x(), v.y(), v.z());
  std::vector<std::vector<std::size_t>> polygons;
  polygons.reserve(mesh.faces.size());
  for (const auto& f : mesh.faces) {
    polygons.push_back({static_cast<std::size_t>(f[0]), static_cast<std::size_t>(f[1]), static_cast<std::size_t>(f[2])});
  }
  // A soup first: merges duplicate points, drops degenerate faces, and makes orientation
  // consistent (splitting non-manifold vertices), which a raw scan or iso-surface may need.
  const std::size_t points_before = points.size();
  PMP::repair_polygon_soup(points, polygons);
  out.duplicate_vertices_merged = points_before > points.size() ? points_before - points.size() : 0;
  PMP::orient_polygon_soup(points, polygons);
  if (polygons.empty()) throw core::Error("repairMesh: no face is left after removing degenerate ones");
  SurfaceMesh surface;
  PMP::polygon_soup_to_polygon_mesh(points, polygons, surface);

  if (config.keep_largest_component) {
    out.components_removed = PMP::keep_largest_connected_components(surface, 1);
  }
  if (config.fill_holes) {
    // Collect one halfedge per boundary loop before changing the mesh.
    std::vector<SurfaceMesh::Halfedge_index> loops;
    std::unordered_set<std::size_t> seen;
    for (const auto h : surface.halfedges()) {
      if (!surface.is_border(h) || seen.count(h.idx())) continue;
      loops.push_back(h);
      for (const auto g : CGAL::halfedges_around_face(h, surface)) seen.insert(g.idx());
    }
    for (const auto h : loops) {
      std::vector<SurfaceMesh::Face_index> new_faces;
      std::vector<SurfaceMesh::Vertex_index> new_vertices;
      PMP::triangulate_and_refine_hole(surface, h, std::back_inserter(new_faces), std::back_inserter(new_vertices));
      if (!new_faces.empty()) ++out.holes_filled;
    }
  }
  surface.collect_garbage();
  core::TriangleMesh result = toTriangleMesh(surface);
  if (result.faces.empty()) throw core::Error("repairMesh: no face is left after repair");
  if (config.orient_outward && analyzeMesh(result).signed_volume < 0) {
    result = flippedFaces(result);
    out.flipped = true;
  }
  if (config.smoothing_iterations > 0) {
    SmoothingConfig smoothing;
    smoothing.iterations = config.smoothing_iterations;
    result = smoothMesh(result, smoothing);
  }
  return result;
}

}  // namespace demnerf::geometry
