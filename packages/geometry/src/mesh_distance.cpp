#include "demnerf/geometry/mesh_distance.hpp"

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>
#include <string>

#include "demnerf/core/error.hpp"

namespace demnerf::geometry {
namespace {

// Distances need no exact predicates: plain double arithmetic is enough and fastest.
using Kernel = CGAL::Simple_cartesian<double>;
using Point = Kernel::Point_3;
using Triangle = Kernel::Triangle_3;
using Primitive = CGAL::AABB_triangle_primitive<Kernel, std::vector<Triangle>::const_iterator>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, Primitive>>;

double triangleArea(const core::TriangleMesh& mesh, std::size_t f) {
  const auto& t = mesh.faces[f];
  return 0.5 * (mesh.vertices[t[1]] - mesh.vertices[t[0]]).cross(mesh.vertices[t[2]] - mesh.vertices[t[0]]).norm();
}

void requireSurface(const core::TriangleMesh& mesh, const char* what) {
  for (std::size_t f = 0; f < mesh.faces.size(); ++f) {
    for (int c = 0; c < 3; ++c) {
      const int v = mesh.faces[f][c];
      if (v < 0 || static_cast<std::size_t>(v) >= mesh.vertices.size()) {
        throw core::Error(std::string(what) + ": face " + std::to_string(f) + " refers to vertex " +
                          std::to_string(v) + " of " + std::to_string(mesh.vertices.size()));
      }
    }
  }
  double area = 0.0;
  for (std::size_t f = 0; f < mesh.faces.size(); ++f) area += triangleArea(mesh, f);
  if (!(area > 0)) {
    throw core::Error(std::string(what) + " has no surface to measure (" + std::to_string(mesh.faces.size()) +
                      " faces, total area " + std::to_string(area) + ")");
  }
}

}  // namespace

std::vector<Eigen::Vector3d> sampleSurfacePoints(const core::TriangleMesh& mesh, std::size_t count,
                                                 std::uint64_t seed) {
  requireSurface(mesh, "mesh");
  std::vector<double> cumulative(mesh.faces.size());
  double total = 0.0;
  for (std::size_t f = 0; f < mesh.faces.size(); ++f) cumulative[f] = (total += triangleArea(mesh, f));
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::vector<Eigen::Vector3d> points;
  points.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    const double pick = uniform(rng) * total;
    const std::size_t f = std::min<std::size_t>(
        std::upper_bound(cumulative.begin(), cumulative.end(), pick) - cumulative.begin(), cumulative.size() - 1);
    // Uniform in the triangle: fold the unit square onto it.
    double s = uniform(rng), t = uniform(rng);
    if (s + t > 1) {
      s = 1 - s;
      t = 1 - t;
    }
    const auto& tri = mesh.faces[f];
    const Eigen::Vector3d& a = mesh.vertices[tri[0]];
    points.push_back(a + s * (mesh.vertices[tri[1]] - a) + t * (mesh.vertices[tri[2]] - a));
  }
  return points;
}

std::vector<double> distancesToMesh(const core::TriangleMesh& mesh, const std::vector<Eigen::Vector3d>& points) {
  requireSurface(mesh, "mesh");
  std::vector<Triangle> triangles;
  triangles.reserve(mesh.faces.size());
  auto point = [](const Eigen::Vector3d& v) { return Point(v.x(), v.y(), v.z()); };
  for (std::size_t f = 0; f < mesh.faces.size(); ++f) {
    if (triangleArea(mesh, f) <= 0) continue;  // CGAL's distance code expects real triangles
    const auto& t = mesh.faces[f];
    triangles.emplace_back(point(mesh.vertices[t[0]]), point(mesh.vertices[t[1]]), point(mesh.vertices[t[2]]));
  }
  Tree tree(triangles.cbegin(), triangles.cend());
  tree.accelerate_distance_queries();
  std::vector<double> distances(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) distances[i] = std::sqrt(tree.squared_distance(point(points[i])));
  return distances;
}

MeshDistance meshDistance(const core::TriangleMesh& a, const core::TriangleMesh& b, const MeshDistanceConfig& config) {
  if (config.samples == 0) throw core::Error("mesh distance: samples must be at least 1, got 0");
  requireSurface(a, "first mesh");
  requireSurface(b, "second mesh");
  const std::vector<double> ab = distancesToMesh(b, sampleSurfacePoints(a, config.samples, config.seed));
  const std::vector<double> ba = distancesToMesh(a, sampleSurfacePoints(b, config.samples, config.seed + 1));
  MeshDistance result;
  for (double d : ab) result.a_to_b_mean += d / ab.size();
  for (double d : ba) result.b_to_a_mean += d / ba.size();
  result.chamfer = 0.5 * (result.a_to_b_mean + result.b_to_a_mean);
  result.chamfer_sum = result.a_to_b_mean + result.b_to_a_mean;
  result.hausdorff = std::max(*std::max_element(ab.begin(), ab.end()), *std::max_element(ba.begin(), ba.end()));
  return result;
}

}  // namespace demnerf::geometry
