#include "demnerf/geometry/mesh_simplification.hpp"

#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Count_stop_predicate.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Edge_length_cost.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Midpoint_placement.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>

#include <string>

#include "demnerf/core/error.hpp"

namespace demnerf::geometry {
namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using Point = Kernel::Point_3;
using SurfaceMesh = CGAL::Surface_mesh<Point>;
namespace SMS = CGAL::Surface_mesh_simplification;

}  // namespace

core::TriangleMesh simplifyMesh(const core::TriangleMesh& mesh, const MeshSimplificationConfig& config,
                                MeshSimplificationReport* report) {
  MeshSimplificationReport local;
  MeshSimplificationReport& r = report ? *report : local;
  r = {};
  r.faces_before = r.faces_after = mesh.faces.size();
  if (config.max_faces == 0 || mesh.faces.size() <= config.max_faces) return mesh;

  SurfaceMesh surface;
  std::vector<SurfaceMesh::Vertex_index> vertices;
  vertices.reserve(mesh.vertices.size());
  for (const auto& v : mesh.vertices) vertices.push_back(surface.add_vertex(Point(v.x(), v.y(), v.z())));
  for (std::size_t f = 0; f < mesh.faces.size(); ++f) {
    const auto& t = mesh.faces[f];
    for (int c = 0; c < 3; ++c) {
      if (t[c] < 0 || static_cast<std::size_t>(t[c]) >= vertices.size()) {
        throw core::Error("simplifyMesh: face " + std::to_string(f) + " refers to vertex " + std::to_string(t[c]) +
                          " of " + std::to_string(vertices.size()));
      }
    }
    if (surface.add_face(vertices[t[0]], vertices[t[1]], vertices[t[2]]) == SurfaceMesh::null_face()) {
      throw core::Error("simplifyMesh: face " + std::to_string(f) +
                        " cannot be added to a manifold surface (repair the mesh first)");
    }
  }
  // Edge collapse counts edges; a closed triangle mesh has 3F/2 of them.
  const SMS::Count_stop_predicate<SurfaceMesh> stop(config.max_faces * 3 / 2);
  if (config.fast) {
    r.edges_collapsed = static_cast<std::size_t>(SMS::edge_collapse(
        surface, stop,
        CGAL::parameters::get_cost(SMS::Edge_length_cost<Kernel>()).get_placement(SMS::Midpoint_placement<Kernel>())));
  } else {
    r.edges_collapsed = static_cast<std::size_t>(SMS::edge_collapse(surface, stop));
  }
  surface.collect_garbage();

  core::TriangleMesh result;
  result.vertices.reserve(surface.number_of_vertices());
  for (const auto v : surface.vertices()) {
    const Point& p = surface.point(v);
    result.vertices.emplace_back(p.x(), p.y(), p.z());
  }
  result.faces.reserve(surface.number_of_faces());
  for (const auto f : surface.faces()) {
    std::array<int, 3> t{};
    int c = 0;
    for (const auto v : CGAL::vertices_around_face(surface.halfedge(f), surface)) t[c++] = static_cast<int>(v.idx());
    result.faces.push_back(t);
  }
  r.faces_after = result.faces.size();
  return result;
}

}  // namespace demnerf::geometry
