#include "demnerf/nerf/renderer.hpp"

#include <ATen/Parallel.h>

#include <chrono>

#include "demnerf/nerf/ray_batch.hpp"

namespace demnerf::nerf {

RenderedImage renderView(const Field& field, const MarchScene& scene, const core::PinholeCamera& camera,
                         const Eigen::Isometry3d& world_from_camera, const Eigen::Vector3f& background) {
  camera.validate();
  const auto start = std::chrono::steady_clock::now();
  const int w = camera.width, h = camera.height;
  const std::int64_t n = static_cast<std::int64_t>(w) * h;
  std::vector<float> origins(3 * n), directions(3 * n);
  const Eigen::Matrix3d r = world_from_camera.linear();
  const Eigen::Vector3d o = world_from_camera.translation();
  at::parallel_for(0, h, 16, [&](std::int64_t begin, std::int64_t end) {
    for (std::int64_t y = begin; y < end; ++y) {
      for (int x = 0; x < w; ++x) {
        Eigen::Vector3d d;
        if (camera.hasDistortion()) {
          d = camera.unproject(Eigen::Vector2d(x + 0.5, y + 0.5));
        } else {
          d = Eigen::Vector3d((x + 0.5 - camera.cx) / camera.fx, (y + 0.5 - camera.cy) / camera.fy, 1.0);
        }
        const Eigen::Vector3d world = (r * d).normalized();
        const std::int64_t i = y * w + x;
        for (int a = 0; a < 3; ++a) {
          origins[3 * i + a] = static_cast<float>(o[a]);
          directions[3 * i + a] = static_cast<float>(world[a]);
        }
      }
    }
  });
  RenderedImage image;
  image.color.create(h, w, CV_32FC3);
  image.depth.create(h, w, CV_32FC1);
  image.opacity.create(h, w, CV_32FC1);
  const float bg[3] = {background.x(), background.y(), background.z()};
  // cv::Mat::create gives continuous storage, so the buffers are the rays' row-major order.
  image.samples = renderRays(field, scene, origins.data(), directions.data(), n, bg,
                             {image.color.ptr<float>(), image.depth.ptr<float>(), image.opacity.ptr<float>()});
  image.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return image;
}

RenderedImage renderImage(const NerfModel& model, const core::PinholeCamera& camera,
                          const Eigen::Isometry3d& world_from_camera, const Eigen::Vector3f& background) {
  const MarchScene scene{model.renderMarch(), model.grid(), model.bounds(), model.config().march.samples_per_round};
  return renderView(model.field(), scene, camera, world_from_camera, background);
}

RenderedImage renderImage(const NerfModel& model, const core::PinholeCamera& camera,
                          const Eigen::Isometry3d& world_from_camera) {
  const auto& b = model.config().background;
  return renderImage(model, camera, world_from_camera,
                     Eigen::Vector3f(static_cast<float>(b[0]), static_cast<float>(b[1]), static_cast<float>(b[2])));
}

cv::Mat toRgba(const RenderedImage& image) {
  cv::Mat rgba(image.color.size(), CV_32FC4);
  const int from_to[] = {0, 0, 1, 1, 2, 2, 3, 3};
  const cv::Mat sources[] = {image.color, image.opacity};
  cv::mixChannels(sources, 2, &rgba, 1, from_to, 4);
  return rgba;
}

}  // namespace demnerf::nerf
