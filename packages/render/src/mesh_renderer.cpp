#include "demnerf/render/mesh_renderer.hpp"

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <mutex>
#include <thread>
#include <vector>

#include "demnerf/core/error.hpp"

namespace demnerf::render {
namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using Triangle = Kernel::Triangle_3;
using TriangleIterator = std::vector<Triangle>::const_iterator;
using Primitive = CGAL::AABB_triangle_primitive<Kernel, TriangleIterator>;
using Tree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, Primitive>>;

void checkMesh(const core::TriangleMesh& mesh, const char* what) {
  if (mesh.faces.empty()) throw core::Error(std::string("renderer: the ") + what + " mesh has no faces");
  const int n = static_cast<int>(mesh.vertices.size());
  for (std::size_t f = 0; f < mesh.faces.size(); ++f) {
    for (int index : mesh.faces[f]) {
      if (index < 0 || index >= n) {
        throw core::Error(std::string("renderer: face ") + std::to_string(f) + " of the " + what +
                          " mesh refers to vertex " + std::to_string(index) + " of " + std::to_string(n));
      }
    }
  }
  for (const auto& v : mesh.vertices) {
    if (!v.allFinite()) throw core::Error(std::string("renderer: the ") + what + " mesh has a non-finite vertex");
  }
}

// One sample's outcome, enough to tell whether a 2x2 pattern straddles an edge.
struct Sample {
  bool hit = false;
  Eigen::Vector3d color = Eigen::Vector3d::Zero();
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  double distance = 0.0;
};

}  // namespace

struct MeshRenderer::Impl {
  core::TriangleMesh rest;
  core::TriangleMesh deformed;
  SurfaceShader shader;
  std::vector<Triangle> triangles;  // the deformed mesh, in face order
  std::vector<Eigen::Vector3d> rest_normals;
  Tree tree;

  Impl(const core::TriangleMesh& rest_mesh, const core::TriangleMesh& deformed_mesh, const SurfaceShader& s)
      : rest(rest_mesh), deformed(deformed_mesh), shader(s) {
    checkMesh(rest, "rest");
    checkMesh(deformed, "deformed");
    if (rest.vertices.size() != deformed.vertices.size() || rest.faces != deformed.faces) {
      throw core::Error("renderer: the deformed mesh must have the rest mesh's vertices and faces (" +
                        std::to_string(rest.vertices.size()) + " vs " + std::to_string(deformed.vertices.size()) +
                        " vertices)");
    }
    triangles.reserve(deformed.faces.size());
    rest_normals.reserve(rest.faces.size());
    const auto point = [](const Eigen::Vector3d& v) { return Kernel::Point_3(v.x(), v.y(), v.z()); };
    for (const auto& f : deformed.faces) {
      triangles.emplace_back(point(deformed.vertices[f[0]]), point(deformed.vertices[f[1]]),
                             point(deformed.vertices[f[2]]));
      const Eigen::Vector3d& a = rest.vertices[f[0]];
      const Eigen::Vector3d n = (rest.vertices[f[1]] - a).cross(rest.vertices[f[2]] - a);
      rest_normals.push_back(n.norm() > 0 ? n.normalized() : Eigen::Vector3d::UnitZ());
    }
    tree.rebuild(triangles.cbegin(), triangles.cend());
    // Build now: the tree would otherwise build lazily on the first query, racing the threads.
    tree.build();
  }

  std::optional<SurfaceHit> cast(const core::Ray& ray) const {
    const Kernel::Ray_3 query(Kernel::Point_3(ray.origin.x(), ray.origin.y(), ray.origin.z()),
                              Kernel::Vector_3(ray.direction.x(), ray.direction.y(), ray.direction.z()));
    const auto primitive = tree.first_intersected_primitive(query);
    if (!primitive) return std::nullopt;
    const int face = static_cast<int>(*primitive - triangles.cbegin());
    const auto& f = deformed.faces[face];
    const Eigen::Vector3d& v0 = deformed.vertices[f[0]];
    const Eigen::Vector3d e1 = deformed.vertices[f[1]] - v0;
    const Eigen::Vector3d e2 = deformed.vertices[f[2]] - v0;
    // Moller-Trumbore for the barycentrics; CGAL already decided that the ray hits, so small
    // round-off outside the triangle is clamped rather than rejected.
    const Eigen::Vector3d p = ray.direction.cross(e2);
    const double det = e1.dot(p);
    if (std::abs(det) < 1e-300) return std::nullopt;
    const Eigen::Vector3d s = ray.origin - v0;
    const Eigen::Vector3d q = s.cross(e1);
    double u = s.dot(p) / det;
    double v = ray.direction.dot(q) / det;
    const double t = e2.dot(q) / det;
    u = std::clamp(u, 0.0, 1.0);
    v = std::clamp(v, 0.0, 1.0);
    if (u + v > 1.0) {
      const double sum = u + v;
      u /= sum;
      v /= sum;
    }
    SurfaceHit hit;
    hit.face = face;
    hit.distance = t;
    hit.point = ray.origin + t * ray.direction;
    const auto& r = rest.vertices;
    hit.rest_point = (1.0 - u - v) * r[f[0]] + u * r[f[1]] + v * r[f[2]];
    Eigen::Vector3d normal = e1.cross(e2).normalized();
    if (normal.dot(ray.direction) > 0) normal = -normal;  // seen from inside: light the side we see
    hit.normal = normal;
    hit.rest_normal = rest_normals[face];
    return hit;
  }

  Sample sample(const core::PinholeCamera& camera, const Eigen::Isometry3d& pose, double u, double v) const {
    Sample result;
    const auto hit = cast(core::generateRay(camera, pose, Eigen::Vector2d(u, v)));
    if (!hit) return result;
    result.hit = true;
    result.color = shader.shade(hit->rest_point, hit->rest_normal, hit->normal);
    result.point = hit->point;
    result.normal = hit->normal;
    result.distance = hit->distance;
    return result;
  }
};

MeshRenderer::MeshRenderer(const core::TriangleMesh& mesh, const SurfaceShader& shader)
    : impl_(std::make_unique<Impl>(mesh, mesh, shader)) {}

MeshRenderer::MeshRenderer(const core::TriangleMesh& rest, const core::TriangleMesh& deformed,
                           const SurfaceShader& shader)
    : impl_(std::make_unique<Impl>(rest, deformed, shader)) {}

MeshRenderer::~MeshRenderer() = default;

std::optional<SurfaceHit> MeshRenderer::castRay(const core::Ray& ray) const { return impl_->cast(ray); }

cv::Mat MeshRenderer::render(const core::PinholeCamera& camera, const Eigen::Isometry3d& world_from_camera,
                             const RenderConfig& config) const {
  camera.validate();
  if (config.samples_per_axis < 1 || config.samples_per_axis > 16) {
    throw core::Error("renderer: samples_per_axis must be in 1..16, got " + std::to_string(config.samples_per_axis));
  }
  const int width = camera.width, height = camera.height, n = config.samples_per_axis;
  cv::Mat image(height, width, CV_32FC4, cv::Scalar(0, 0, 0, 0));
  const Impl& impl = *impl_;
  // A sample's position inside its pixel: stratum (a, b) of an m x m grid, jittered by a hash of
  // the pixel, so the image depends on nothing but the inputs.
  const auto jitter = [&](int x, int y, int m, int index, int axis) {
    return hashUnit(hashMix(config.seed, static_cast<std::uint64_t>(y) * 65536u + x,
                            static_cast<std::uint64_t>(m) * 4096u + index, axis));
  };
  const auto renderRow = [&](int y) {
    auto* row = image.ptr<cv::Vec4f>(y);
    std::vector<Sample> samples;
    for (int x = 0; x < width; ++x) {
      samples.clear();
      bool refine = true;
      if (config.adaptive && n > 2) {
        for (int index = 0; index < 4; ++index) {
          const int a = index % 2, b = index / 2;
          samples.push_back(impl.sample(camera, world_from_camera, x + (a + jitter(x, y, 2, index, 0)) / 2.0,
                                        y + (b + jitter(x, y, 2, index, 1)) / 2.0));
        }
        refine = false;
        const Sample& first = samples.front();
        // Tolerance for "same plane": a hundredth of the pixel's footprint at that depth.
        const double tolerance = 0.01 * std::max(first.distance, 1e-9) / camera.fx;
        for (const Sample& s : samples) {
          if (s.hit != first.hit) refine = true;
          else if (s.hit && (s.normal.dot(first.normal) < 0.999 ||
                             std::abs(first.normal.dot(s.point - first.point)) > tolerance)) refine = true;
        }
      }
      if (refine) {
        samples.clear();
        for (int index = 0; index < n * n; ++index) {
          const int a = index % n, b = index / n;
          samples.push_back(impl.sample(camera, world_from_camera, x + (a + jitter(x, y, n, index, 0)) / n,
                                        y + (b + jitter(x, y, n, index, 1)) / n));
        }
      }
      Eigen::Vector3d color = Eigen::Vector3d::Zero();
      int hits = 0;
      for (const Sample& s : samples) {
        if (!s.hit) continue;
        color += s.color;
        ++hits;
      }
      if (hits == 0) continue;
      color /= hits;
      row[x] = cv::Vec4f(static_cast<float>(color.x()), static_cast<float>(color.y()),
                         static_cast<float>(color.z()),
                         static_cast<float>(static_cast<double>(hits) / samples.size()));
    }
  };
  int threads = config.threads > 0 ? config.threads : static_cast<int>(std::thread::hardware_concurrency());
  threads = std::max(1, std::min(threads, height));
  // Rows are dealt round-robin: the object sits in the middle rows, so blocks would idle threads.
  std::vector<std::thread> workers;
  std::exception_ptr failure;
  std::mutex failure_mutex;
  for (int t = 0; t < threads; ++t) {
    workers.emplace_back([&, t] {
      try {
        for (int y = t; y < height; y += threads) renderRow(y);
      } catch (...) {
        std::lock_guard<std::mutex> lock(failure_mutex);
        if (!failure) failure = std::current_exception();
      }
    });
  }
  for (auto& worker : workers) worker.join();
  if (failure) std::rethrow_exception(failure);
  return image;
}

}  // namespace demnerf::render
