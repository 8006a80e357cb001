#include "demnerf/render/mesh_renderer.hpp"

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Simple_cartesian.h>

#include <algorithm>
#include <cmath>
#include <functional>
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

/// The rest and deformed meshes each valid, with the same vertices and faces: a hit's
/// barycentrics on the deformed face must name the same material point at rest.
void checkPair(const core::TriangleMesh& rest, const core::TriangleMesh& deformed) {
  checkMesh(rest, "rest");
  checkMesh(deformed, "deformed");
  if (rest.vertices.size() != deformed.vertices.size() || rest.faces != deformed.faces) {
    throw core::Error("renderer: the deformed mesh must have the rest mesh's vertices and faces (" +
                      std::to_string(rest.vertices.size()) + " vs " + std::to_string(deformed.vertices.size()) +
                      " vertices)");
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
    checkPair(rest, deformed);
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

  void stratified(const core::PinholeCamera& camera, const Eigen::Isometry3d& pose, std::uint64_t seed, int x, int y,
                  int m, std::vector<Sample>& out) const;
};

MeshRenderer::MeshRenderer(const core::TriangleMesh& mesh, const SurfaceShader& shader)
    : impl_(std::make_unique<Impl>(mesh, mesh, shader)) {}

MeshRenderer::MeshRenderer(const core::TriangleMesh& rest, const core::TriangleMesh& deformed,
                           const SurfaceShader& shader)
    : impl_(std::make_unique<Impl>(rest, deformed, shader)) {}

MeshRenderer::~MeshRenderer() = default;

std::optional<SurfaceHit> MeshRenderer::castRay(const core::Ray& ray) const { return impl_->cast(ray); }

namespace {

/// Whether a pixel's 2x2 pattern straddles an edge: some samples miss, or the hits leave the
/// first hit's plane (crease or depth step). The plane tolerance is a hundredth of the pixel's
/// footprint at that depth.
bool straddlesEdge(const std::vector<Sample>& samples, double fx) {
  const Sample& first = samples.front();
  const double tolerance = 0.01 * std::max(first.distance, 1e-9) / fx;
  for (const Sample& s : samples) {
    if (s.hit != first.hit) return true;
    if (s.hit && (s.normal.dot(first.normal) < 0.999 || std::abs(first.normal.dot(s.point - first.point)) > tolerance)) {
      return true;
    }
  }
  return false;
}

/// Straight-alpha RGBA of a pixel: the mean colour of the samples that hit, alpha their share.
cv::Vec4f averagePixel(const std::vector<Sample>& samples) {
  Eigen::Vector3d color = Eigen::Vector3d::Zero();
  int hits = 0;
  for (const Sample& s : samples) {
    if (!s.hit) continue;
    color += s.color;
    ++hits;
  }
  if (hits == 0) return cv::Vec4f(0, 0, 0, 0);
  color /= hits;
  return cv::Vec4f(static_cast<float>(color.x()), static_cast<float>(color.y()), static_cast<float>(color.z()),
                   static_cast<float>(static_cast<double>(hits) / samples.size()));
}

/// Runs row(y) for every row on `threads` threads and rethrows the first failure. Rows are
/// dealt round-robin: the object sits in the middle rows, so blocks would idle threads.
void forEachRow(int height, int threads, const std::function<void(int)>& row) {
  std::vector<std::thread> workers;
  std::exception_ptr failure;
  std::mutex failure_mutex;
  for (int t = 0; t < threads; ++t) {
    workers.emplace_back([&, t] {
      try {
        for (int y = t; y < height; y += threads) row(y);
      } catch (...) {
        std::lock_guard<std::mutex> lock(failure_mutex);
        if (!failure) failure = std::current_exception();
      }
    });
  }
  for (auto& worker : workers) worker.join();
  if (failure) std::rethrow_exception(failure);
}

}  // namespace

/// The samples of one pixel on an m x m grid of strata, each jittered by a hash of the pixel,
/// so the image depends on nothing but the inputs.
void MeshRenderer::Impl::stratified(const core::PinholeCamera& camera, const Eigen::Isometry3d& pose,
                                    std::uint64_t seed, int x, int y, int m, std::vector<Sample>& out) const {
  out.clear();
  for (int index = 0; index < m * m; ++index) {
    const int a = index % m, b = index / m;
    const auto jitter = [&](int axis) {
      return hashUnit(hashMix(seed, static_cast<std::uint64_t>(y) * 65536u + x,
                              static_cast<std::uint64_t>(m) * 4096u + index, axis));
    };
    out.push_back(sample(camera, pose, x + (a + jitter(0)) / m, y + (b + jitter(1)) / m));
  }
}

cv::Mat MeshRenderer::render(const core::PinholeCamera& camera, const Eigen::Isometry3d& world_from_camera,
                             const RenderConfig& config) const {
  camera.validate();
  if (config.samples_per_axis < 1 || config.samples_per_axis > 16) {
    throw core::Error("renderer: samples_per_axis must be in 1..16, got " + std::to_string(config.samples_per_axis));
  }
  const int height = camera.height, n = config.samples_per_axis;
  cv::Mat image(height, camera.width, CV_32FC4, cv::Scalar(0, 0, 0, 0));
  const Impl& impl = *impl_;
  const auto renderRow = [&](int y) {
    auto* row = image.ptr<cv::Vec4f>(y);
    std::vector<Sample> samples;
    for (int x = 0; x < camera.width; ++x) {
      // Adaptive: a 2x2 pattern first; all n x n samples only where it sees an edge.
      const bool pattern = config.adaptive && n > 2;
      if (pattern) impl.stratified(camera, world_from_camera, config.seed, x, y, 2, samples);
      if (!pattern || straddlesEdge(samples, camera.fx)) {
        impl.stratified(camera, world_from_camera, config.seed, x, y, n, samples);
      }
      row[x] = averagePixel(samples);
    }
  };
  int threads = config.threads > 0 ? config.threads : static_cast<int>(std::thread::hardware_concurrency());
  forEachRow(height, std::max(1, std::min(threads, height)), renderRow);
  return image;
}

}  // namespace demnerf::render
