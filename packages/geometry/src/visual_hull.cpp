#include "demnerf/geometry/visual_hull.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "demnerf/core/error.hpp"

namespace demnerf::geometry {
namespace {

// A camera set up to project many world points: the world-to-optical map, and how far from the
// axis (squared, in undistorted normalised coordinates) its image reaches. Beyond that reach the
// Brown-Conrady polynomial can fold far-away points back into the frame, so they are refused.
struct Projector {
  const core::PinholeCamera& camera;
  Eigen::Matrix3d rotation;
  Eigen::Vector3d translation;
  double max_r2 = 0.0;

  explicit Projector(const ViewCamera& view) : camera(view.camera) {
    const Eigen::Isometry3d camera_from_world = view.world_from_camera.inverse();
    rotation = camera_from_world.linear();
    translation = camera_from_world.translation();
    const double w = camera.width, h = camera.height;
    for (const Eigen::Vector2d corner : {Eigen::Vector2d(0, 0), Eigen::Vector2d(w, 0), Eigen::Vector2d(0, h),
                                         Eigen::Vector2d(w, h)}) {
      const Eigen::Vector2d distorted((corner.x() - camera.cx) / camera.fx, (corner.y() - camera.cy) / camera.fy);
      max_r2 = std::max(max_r2, camera.undistort(distorted).squaredNorm());
    }
    max_r2 *= 1.5;  // room for the depth of body cubes just outside the frame
  }

  // The point in the optical frame and its pixel; false when it is behind the camera or beyond
  // the image's reach.
  bool project(const Eigen::Vector3d& world, Eigen::Vector3d* local, Eigen::Vector2d* pixel) const {
    *local = rotation * world + translation;
    if (!(local->z() > 0.0)) return false;
    const Eigen::Vector2d normalized = local->head<2>() / local->z();
    if (normalized.squaredNorm() > max_r2) return false;
    const Eigen::Vector2d d = camera.distort(normalized);
    *pixel = Eigen::Vector2d(camera.fx * d.x() + camera.cx, camera.fy * d.y() + camera.cy);
    return true;
  }

  bool inImage(const Eigen::Vector2d& pixel) const {
    return pixel.x() >= 0.0 && pixel.y() >= 0.0 && pixel.x() < camera.width && pixel.y() < camera.height;
  }
};

// The depth (optical z) of the nearest body cube seen through each texel of a camera's image,
// +inf where the body is not in the way. A texel spans `texel` pixels on each side.
struct DepthMap {
  int width = 0, height = 0;
  double texel = 1.0;
  std::vector<float> depth;

  float at(const Eigen::Vector2d& pixel) const {
    const int x = std::min(width - 1, static_cast<int>(pixel.x() / texel));
    const int y = std::min(height - 1, static_cast<int>(pixel.y() / texel));
    return depth[static_cast<std::size_t>(y) * width + x];
  }
};

// Splats each body point as a square as wide as its cube's circumscribed sphere (so neighbouring
// cubes' squares overlap and leave no cracks for rays to slip through), keeping the nearest depth.
// Texels are sized so that one cell spans about two of them where the body is farthest away.
DepthMap renderBody(const std::vector<Eigen::Vector3d>& points, const Projector& projector, double half_diagonal) {
  const core::PinholeCamera& camera = projector.camera;
  const double focal = std::min(camera.fx, camera.fy);
  std::vector<Eigen::Vector3d> local(points.size());
  std::vector<Eigen::Vector2d> pixels(points.size());
  std::vector<char> valid(points.size(), 0);
  double far = 0.0;
  for (std::size_t p = 0; p < points.size(); ++p) {
    valid[p] = projector.project(points[p], &local[p], &pixels[p]);
    if (valid[p]) far = std::max(far, local[p].z());
  }
  DepthMap map;
  map.texel = far > 0.0 ? std::max(1.0, focal * half_diagonal / (1.7 * far)) : 1.0;
  map.width = std::max(1, static_cast<int>(std::ceil(camera.width / map.texel)));
  map.height = std::max(1, static_cast<int>(std::ceil(camera.height / map.texel)));
  map.depth.assign(static_cast<std::size_t>(map.width) * map.height, std::numeric_limits<float>::infinity());
  for (std::size_t p = 0; p < points.size(); ++p) {
    if (!valid[p]) continue;
    const double z = local[p].z();
    const double half = std::min(4096.0, focal * half_diagonal / (z * map.texel));  // in texels
    const double u = pixels[p].x() / map.texel, v = pixels[p].y() / map.texel;
    // Texel x covers [x, x + 1): its centre x + 0.5 lies within `half` of u.
    const int x0 = std::max(0, static_cast<int>(std::ceil(u - half - 0.5)));
    const int x1 = std::min(map.width - 1, static_cast<int>(std::floor(u + half - 0.5)));
    const int y0 = std::max(0, static_cast<int>(std::ceil(v - half - 0.5)));
    const int y1 = std::min(map.height - 1, static_cast<int>(std::floor(v + half - 0.5)));
    const float depth = static_cast<float>(z);
    for (int y = y0; y <= y1; ++y) {
      float* row = map.depth.data() + static_cast<std::size_t>(y) * map.width;
      for (int x = x0; x <= x1; ++x) row[x] = std::min(row[x], depth);
    }
  }
  return map;
}

// The body nodes a ray from outside can meet first: those with a non-body 6-neighbour or on the
// grid's border (rays enter there from beyond the box). Interior nodes hide nothing more.
std::vector<Eigen::Vector3d> bodyBoundary(const DensityGrid& grid, const std::vector<char>& body) {
  const Eigen::Vector3i& n = grid.dims;
  std::vector<Eigen::Vector3d> points;
  for (int k = 0; k < n.z(); ++k) {
    for (int j = 0; j < n.y(); ++j) {
      for (int i = 0; i < n.x(); ++i) {
        if (!body[grid.index(i, j, k)]) continue;
        const bool border = i == 0 || j == 0 || k == 0 || i == n.x() - 1 || j == n.y() - 1 || k == n.z() - 1;
        if (border || !body[grid.index(i - 1, j, k)] || !body[grid.index(i + 1, j, k)] ||
            !body[grid.index(i, j - 1, k)] || !body[grid.index(i, j + 1, k)] || !body[grid.index(i, j, k - 1)] ||
            !body[grid.index(i, j, k + 1)])
          points.push_back(grid.node(i, j, k));
      }
    }
  }
  return points;
}

void validateCameras(const DensityGrid& grid, const std::vector<char>& body, const std::vector<ViewCamera>& cameras) {
  if (body.size() != grid.values.size()) throw core::Error("unseenByCameras: the body mask does not match the grid");
  if (cameras.empty()) throw core::Error("space carving needs at least one camera of the capture");
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    try {
      cameras[c].camera.validate();
    } catch (const core::Error& error) {
      std::ostringstream message;
      message << "space carving: camera " << c << ": " << error.what();
      throw core::Error(message.str());
    }
    if (!cameras[c].world_from_camera.matrix().allFinite()) {
      throw core::Error("space carving: camera " + std::to_string(c) + "'s pose is not finite");
    }
  }
}

}  // namespace

std::vector<char> unseenByCameras(const DensityGrid& grid, const std::vector<char>& body,
                                  const std::vector<ViewCamera>& cameras, int min_views, CarvingReport* report) {
  validateCameras(grid, body, cameras);
  if (min_views < 1) throw core::Error("space carving: min_views must be >= 1, got " + std::to_string(min_views));
  const double half_diagonal = 0.5 * grid.spacing.norm();
  const std::vector<Eigen::Vector3d> boundary = bodyBoundary(grid, body);
  std::vector<char> seen(body.size(), 0), framed(body.size(), 0);
  std::vector<int> views(body.size(), 0);  // cameras that saw the node in plain view
  const Eigen::Vector3i& n = grid.dims;
  for (const ViewCamera& view : cameras) {
    const Projector projector(view);
    const DepthMap map = renderBody(boundary, projector, half_diagonal);
    for (int k = 0; k < n.z(); ++k) {
      for (int j = 0; j < n.y(); ++j) {
        for (int i = 0; i < n.x(); ++i) {
          const std::size_t id = grid.index(i, j, k);
          if (body[id] || seen[id]) continue;
          Eigen::Vector3d local;
          Eigen::Vector2d pixel;
          if (!projector.project(grid.node(i, j, k), &local, &pixel) || !projector.inImage(pixel)) continue;
          framed[id] = 1;
          // Hidden only when the node lies clearly behind the nearest cube on its line of sight:
          // a node beside the body, level with its surface, is in plain view.
          if (!(local.z() > map.at(pixel) + half_diagonal)) ++views[id];
          seen[id] = views[id] >= min_views;
        }
      }
    }
  }
  CarvingReport local_report;
  CarvingReport& out = report ? *report : local_report;
  out = CarvingReport{};
  std::vector<char> unseen(body.size(), 0);
  for (std::size_t id = 0; id < body.size(); ++id) {
    if (body[id]) continue;
    unseen[id] = !seen[id];
    ++(seen[id] ? out.seen_empty : framed[id] ? out.hidden : out.unseen);
  }
  return unseen;
}

}  // namespace demnerf::geometry
