#include <gtest/gtest.h>

#include <cmath>

#include "demnerf/core/error.hpp"
#include "demnerf/core/ray.hpp"
#include "demnerf/render/camera_rig.hpp"
#include "demnerf/render/mesh_renderer.hpp"
#include "demnerf/render/scene_geometry.hpp"
#include "demnerf/render/synthetic_scene.hpp"

namespace demnerf::render {
namespace {

bool identical(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() &&
         std::equal(a.datastart, a.dataend, b.datastart);
}

TEST(MeshRenderer, ProjectedVertexIsWhereItsRayHitsTheMesh) {
  const SceneObject object = makeSceneObject(SceneKind::kTBar);
  const auto& mesh = object.mesh;
  const MeshRenderer renderer(mesh, makeSceneShader(object, 0));
  CameraRigConfig config;
  config.train_views = 12;
  config.test_views = 0;
  config.width = config.height = 120;
  const CameraRig rig = makeCameraRig(object.bounds, config);
  RenderConfig render_config;
  render_config.samples_per_axis = 2;
  for (const auto& pose : rig.train) {
    const Eigen::Vector3d eye = pose.translation();
    // Vertices whose every face is turned towards the camera (not on a silhouette, so the
    // pixel around them is covered by the surface); the nearest of them is not hidden.
    std::vector<bool> facing(mesh.vertices.size(), true);
    for (const auto& f : mesh.faces) {
      const Eigen::Vector3d& a = mesh.vertices[f[0]];
      const Eigen::Vector3d n = (mesh.vertices[f[1]] - a).cross(mesh.vertices[f[2]] - a).normalized();
      const bool front = n.dot((eye - a).normalized()) > 0.3;
      for (int v : f) facing[v] = facing[v] && front;
    }
    int vertex = -1;
    for (std::size_t v = 0; v < mesh.vertices.size(); ++v) {
      if (facing[v] && (vertex < 0 || (mesh.vertices[v] - eye).norm() < (mesh.vertices[vertex] - eye).norm())) {
        vertex = static_cast<int>(v);
      }
    }
    ASSERT_GE(vertex, 0);
    const Eigen::Vector3d& target = mesh.vertices[vertex];
    const Eigen::Vector2d projected = rig.camera.project(pose.inverse() * target);
    // The ray through the centre of the pixel the vertex lands on.
    const Eigen::Vector2d centre(std::floor(projected.x()) + 0.5, std::floor(projected.y()) + 0.5);
    const auto hit = renderer.castRay(core::generateRay(rig.camera, pose, centre));
    ASSERT_TRUE(hit.has_value());
    // Within a pixel: at most half a pixel diagonal on the image plane, which the surface
    // stretches by at most 1 / 0.3 at this obliqueness.
    const double footprint = (target - eye).norm() / rig.camera.fx;
    EXPECT_LT((hit->point - target).norm(), 0.71 * footprint / 0.3) << "vertex " << vertex;
    EXPECT_LT((hit->rest_point - hit->point).norm(), 1e-12);
    // And the rendered image is opaque there.
    const cv::Mat image = renderer.render(rig.camera, pose, render_config);
    const cv::Vec4f rgba = image.at<cv::Vec4f>(static_cast<int>(centre.y()), static_cast<int>(centre.x()));
    EXPECT_EQ(rgba[3], 1.0f);
  }
}

TEST(MeshRenderer, CuboidCoverageMatchesItsAnalyticSilhouette) {
  // Far camera on the +x axis, looking down -x, with a long focal length: nearly orthographic.
  // The silhouette is the square front face x = 0.125, whose projection is exact.
  const CuboidDimensions d;
  const core::TriangleMesh mesh = makeCuboidMesh(d, 0.01);
  SceneObject object = makeSceneObject(SceneKind::kCuboid);
  const MeshRenderer renderer(mesh, makeSceneShader(object, 0));
  const double distance = 20.0;
  const Eigen::Isometry3d pose = lookAt(Eigen::Vector3d(distance, 0.0043, -0.0031), Eigen::Vector3d(0, 0.0043, -0.0031),
                                        Eigen::Vector3d::UnitZ());
  core::PinholeCamera camera;
  camera.width = camera.height = 160;
  camera.fx = camera.fy = 24000.0;  // 0.1 m at 20 m -> 120 px
  camera.cx = camera.cy = 80.0;
  const cv::Mat image = renderer.render(camera, pose, RenderConfig{});
  double coverage = 0.0;
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 0; x < image.cols; ++x) coverage += image.at<cv::Vec4f>(y, x)[3];
  }
  const double side_px = camera.fx * d.width / (distance - d.length);
  const double expected = side_px * side_px;
  EXPECT_NEAR(coverage / expected, 1.0, 0.01) << "coverage " << coverage << " px^2, analytic " << expected;
  // Transparent outside, opaque inside.
  EXPECT_EQ(image.at<cv::Vec4f>(2, 2)[3], 0.0f);
  EXPECT_EQ(image.at<cv::Vec4f>(80, 80)[3], 1.0f);
}

TEST(MeshRenderer, SameInputsGiveBitwiseIdenticalImagesWhateverTheThreads) {
  const SceneObject object = makeSceneObject(SceneKind::kTBar);
  const MeshRenderer renderer(object.mesh, makeSceneShader(object, 3));
  CameraRigConfig config;
  config.train_views = 2;
  config.test_views = 0;
  config.width = config.height = 64;
  const CameraRig rig = makeCameraRig(object.bounds, config);
  RenderConfig one;
  one.threads = 1;
  RenderConfig many;
  many.threads = 3;
  const cv::Mat a = renderer.render(rig.camera, rig.train[1], one);
  const cv::Mat b = renderer.render(rig.camera, rig.train[1], many);
  const cv::Mat c = renderer.render(rig.camera, rig.train[1], many);
  EXPECT_TRUE(identical(a, b));
  EXPECT_TRUE(identical(b, c));
  // And the seed matters: another jitter gives another (but close) image.
  RenderConfig other = many;
  other.seed = 99;
  EXPECT_FALSE(identical(a, renderer.render(rig.camera, rig.train[1], other)));
}

TEST(MeshRenderer, ClosedMeshShowsNoPinholes) {
  // Rays through shared edges and vertices must not slip between triangles: inside the
  // silhouette every pixel is fully covered.
  const SceneObject object = makeSceneObject(SceneKind::kTBar);
  const MeshRenderer renderer(object.mesh, makeSceneShader(object, 0));
  CameraRigConfig config;
  config.train_views = 6;
  config.test_views = 0;
  config.width = config.height = 100;
  const CameraRig rig = makeCameraRig(object.bounds, config);
  RenderConfig render_config;
  render_config.adaptive = false;
  render_config.samples_per_axis = 3;
  int opaque = 0;
  for (const auto& pose : rig.train) {
    const cv::Mat image = renderer.render(rig.camera, pose, render_config);
    for (int y = 1; y + 1 < image.rows; ++y) {
      for (int x = 1; x + 1 < image.cols; ++x) {
        bool surrounded = true;
        for (int dy = -1; dy <= 1; ++dy) {
          for (int dx = -1; dx <= 1; ++dx) {
            if ((dx || dy) && image.at<cv::Vec4f>(y + dy, x + dx)[3] < 1.0f) surrounded = false;
          }
        }
        if (!surrounded) continue;
        ++opaque;
        EXPECT_EQ(image.at<cv::Vec4f>(y, x)[3], 1.0f) << "pinhole at (" << x << ", " << y << ")";
      }
    }
  }
  EXPECT_GT(opaque, 1000);
}

TEST(MeshRenderer, AdaptiveSamplingAgreesWithFullSampling) {
  const SceneObject object = makeSceneObject(SceneKind::kTBar);
  const MeshRenderer renderer(object.mesh, makeSceneShader(object, 0));
  CameraRigConfig config;
  config.train_views = 3;
  config.test_views = 0;
  config.width = config.height = 80;
  const CameraRig rig = makeCameraRig(object.bounds, config);
  RenderConfig adaptive;
  RenderConfig full;
  full.adaptive = false;
  const cv::Mat a = renderer.render(rig.camera, rig.train[2], adaptive);
  const cv::Mat b = renderer.render(rig.camera, rig.train[2], full);
  std::vector<cv::Mat> ca, cb;
  cv::split(a, ca);
  cv::split(b, cb);
  // Coverage (the object's outline) must agree closely; colours differ only by texture sampling.
  EXPECT_NEAR(cv::sum(ca[3])[0], cv::sum(cb[3])[0], 0.002 * cv::sum(cb[3])[0]);
  EXPECT_LT(cv::norm(a, b, cv::NORM_L1) / (a.total() * 4), 0.01);
}

TEST(MeshRenderer, DeformedMeshIsTexturedByItsRestPosition) {
  const SceneObject object = makeSceneObject(SceneKind::kCuboid);
  core::TriangleMesh moved = object.mesh;
  const Eigen::Vector3d shift(0.0, 0.02, 0.01);
  for (auto& v : moved.vertices) v += shift;
  const MeshRenderer renderer(object.mesh, moved, makeSceneShader(object, 0));
  core::Ray ray;
  ray.origin = Eigen::Vector3d(1.0, 0.031, 0.012);
  ray.direction = -Eigen::Vector3d::UnitX();
  const auto hit = renderer.castRay(ray);
  ASSERT_TRUE(hit.has_value());
  EXPECT_NEAR(hit->point.x(), 0.125, 1e-12);
  EXPECT_LT((hit->rest_point - (hit->point - shift)).norm(), 1e-12);
  EXPECT_LT((hit->normal - Eigen::Vector3d::UnitX()).norm(), 1e-12);
  // A mesh with other faces cannot be the deformed one.
  core::TriangleMesh other = moved;
  other.faces.pop_back();
  EXPECT_THROW(MeshRenderer(object.mesh, other, makeSceneShader(object, 0)), core::Error);
}

}  // namespace
}  // namespace demnerf::render
