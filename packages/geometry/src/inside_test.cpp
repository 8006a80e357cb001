#include "demnerf/geometry/inside_test.hpp"

#include <CGAL/AABB_face_graph_triangle_primitive.h>
#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Side_of_triangle_mesh.h>
#include <CGAL/Surface_mesh.h>

#include "demnerf/core/error.hpp"
#include "demnerf/geometry/mesh_analysis.hpp"

namespace demnerf::geometry {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using SurfaceMesh = CGAL::Surface_mesh<Point>;
using Primitive = CGAL::AABB_face_graph_triangle_primitive<SurfaceMesh>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, Primitive>>;
using Side = CGAL::Side_of_triangle_mesh<SurfaceMesh, Kernel, CGAL::Default, Tree>;

}  // namespace

struct InsideTest::Impl {
  SurfaceMesh surface;
  Tree tree;
  std::unique_ptr<Side> side;
};

InsideTest::InsideTest(const core::TriangleMesh& mesh, const std::string& what) : impl_(std::make_unique<Impl>()) {
  // Side_of_triangle_mesh shoots rays and counts crossings, so it needs a closed surface;
  // orientation does not matter to it.
  requireClosedMesh(mesh, what);
  std::vector<SurfaceMesh::Vertex_index> vertices;
  vertices.reserve(mesh.vertices.size());
  for (const auto& v : mesh.vertices) vertices.push_back(impl_->surface.add_vertex(Point(v.x(), v.y(), v.z())));
  for (std::size_t i = 0; i < mesh.faces.size(); ++i) {
    const auto& f = mesh.faces[i];
    if (impl_->surface.add_face(vertices[f[0]], vertices[f[1]], vertices[f[2]]) == SurfaceMesh::null_face()) {
      throw core::Error(what + " is not a manifold surface: face " + std::to_string(i) +
                        " cannot be attached (a vertex is shared by separate sheets)");
    }
  }
  impl_->tree.insert(faces(impl_->surface).first, faces(impl_->surface).second, impl_->surface);
  impl_->tree.build();
  impl_->tree.accelerate_distance_queries();
  impl_->side = std::make_unique<Side>(impl_->tree);
}

InsideTest::~InsideTest() = default;
InsideTest::InsideTest(InsideTest&&) noexcept = default;
InsideTest& InsideTest::operator=(InsideTest&&) noexcept = default;

bool InsideTest::inside(const Eigen::Vector3d& point) const {
  return (*impl_->side)(Point(point.x(), point.y(), point.z())) == CGAL::ON_BOUNDED_SIDE;
}

double InsideTest::squaredDistance(const Eigen::Vector3d& point) const {
  return CGAL::to_double(impl_->tree.squared_distance(Point(point.x(), point.y(), point.z())));
}

}  // namespace demnerf::geometry
