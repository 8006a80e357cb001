// The deformed renderer against the undeformed one, on a small untrained NeRF whose hash
// table is scaled up so its density varies strongly (a textured cloud), confined by its
// occupancy grid to a cube that the particles fill.

#include <gtest/gtest.h>

#include <ATen/Parallel.h>

#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <random>

#include "demnerf/core/error.hpp"
#include "demnerf/core/metrics.hpp"
#include "demnerf/render/camera_rig.hpp"
#include "demnerf/render/deformed_renderer.hpp"

using namespace demnerf;

namespace {

constexpr float kLo = 0.3f, kHi = 0.7f;  // the cube the NeRF occupies, in a [0, 1]^3 box

nerf::NerfModel makeModel() {
  nerf::NerfConfig config;
  config.hash.levels = 8;
  config.hash.log2_table_size = 14;
  config.hash.finest_resolution = 64;
  config.occupancy.resolution = 32;
  nerf::Box box;  // [0, 1]^3
  nerf::NerfModel model(config, box, 1.0);
  // Features of order 1 and a louder density network: a strongly textured, nearly opaque cloud.
  for (float& v : model.ngp().table()) v *= 2e4f;
  for (float& v : model.ngp().densityWeights()) v *= 3.0f;
  model.ngp().refreshTransposed();
  auto& grid = model.grid();
  std::fill(grid.bits().begin(), grid.bits().end(), 0);
  const int r = grid.resolution();
  for (int z = 0; z < r; ++z)
    for (int y = 0; y < r; ++y)
      for (int x = 0; x < r; ++x) {
        const float c[3] = {(x + 0.5f) / r, (y + 0.5f) / r, (z + 0.5f) / r};
        bool in = true;
        for (float v : c) in = in && v > kLo && v < kHi;
        if (!in) continue;
        const std::int64_t cell = (static_cast<std::int64_t>(z) * r + y) * r + x;
        grid.bits()[cell >> 3] |= static_cast<std::uint8_t>(1u << (cell & 7));
      }
  return model;
}

/// Jittered lattice particles filling the occupied cube (and a little beyond), with u(X).
core::ResultField makeResult(const Eigen::Vector3d& shift) {
  core::ResultField result;
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> jitter(-0.004, 0.004);
  const int k = 12;
  for (int z = 0; z <= k; ++z)
    for (int y = 0; y <= k; ++y)
      for (int x = 0; x <= k; ++x) {
        Eigen::Vector3d p(0.27 + 0.46 * x / k, 0.27 + 0.46 * y / k, 0.27 + 0.46 * z / k);
        for (int a = 0; a < 3; ++a) p[a] += jitter(rng);
        result.positions.push_back(p);
        result.displacements.push_back(shift);
        result.von_mises.push_back(0.0);
      }
  return result;
}

core::PinholeCamera makeCamera(int size) {
  core::PinholeCamera camera;
  camera.width = camera.height = size;
  camera.fx = camera.fy = 1.2 * size;
  camera.cx = camera.cy = 0.5 * size;
  return camera;
}

Eigen::Isometry3d view() {
  return render::lookAt(Eigen::Vector3d(2.2, 1.3, 1.6), Eigen::Vector3d(0.5, 0.5, 0.5), Eigen::Vector3d::UnitZ());
}

double psnr(const cv::Mat& a, const cv::Mat& b) {
  const double mse = cv::norm(a, b, cv::NORM_L2SQR) / static_cast<double>(a.total() * a.channels());
  return mse > 0 ? 10.0 * std::log10(1.0 / mse) : std::numeric_limits<double>::infinity();
}

Eigen::Vector2d opacityCentroid(const cv::Mat& opacity) {
  double sum = 0, sx = 0, sy = 0;
  for (int y = 0; y < opacity.rows; ++y)
    for (int x = 0; x < opacity.cols; ++x) {
      const double o = opacity.at<float>(y, x);
      sum += o;
      sx += o * x;
      sy += o * y;
    }
  return Eigen::Vector2d(sx / sum, sy / sum);
}

const Eigen::Vector3f kBackground(1.0f, 1.0f, 1.0f);

}  // namespace

TEST(DeformedRenderer, TestModelIsATexturedOpaqueCube) {
  const nerf::NerfModel model = makeModel();
  const auto image = nerf::renderImage(model, makeCamera(64), view(), kBackground);
  double lo = 1, hi = 0;
  cv::minMaxLoc(image.opacity, &lo, &hi);
  EXPECT_GT(hi, 0.9) << "the cube should be nearly opaque somewhere";
  EXPECT_LT(lo, 0.01) << "the cube should not fill the view";
  cv::Scalar mean, stddev;
  cv::meanStdDev(image.color, mean, stddev, image.opacity > 0.5);
  EXPECT_GT(stddev[0], 0.02) << "the colour should vary across the cube";
}

TEST(DeformedRenderer, ZeroDisplacementRendersTheUndeformedImage) {
  const nerf::NerfModel model = makeModel();
  const render::DeformedScene scene(model, makeResult(Eigen::Vector3d::Zero()));
  EXPECT_GT(scene.embedding().tetCount(), 1000u);
  const auto camera = makeCamera(64);
  const auto rest = nerf::renderImage(model, camera, view(), kBackground);
  const auto deformed = render::renderDeformed(scene, camera, view(), kBackground);
  EXPECT_GE(psnr(rest.color, deformed.color), 40.0);
  // Not bit-identical: the NeRF's marcher jumps over empty cells on its step lattice and so
  // skips the sample that straddles the entry of an occupied run; the deformed grid is occupied
  // a little wider (the body's margin), so there that sample is taken.
  EXPECT_LT(cv::norm(rest.opacity, deformed.opacity, cv::NORM_L1) / static_cast<double>(rest.opacity.total()), 0.01);
}

TEST(DeformedRenderer, RigidTranslationRendersTheShiftedImage) {
  const nerf::NerfModel model = makeModel();
  const Eigen::Vector3d shift(0.0, -0.12, 0.08);
  const render::DeformedScene scene(model, makeResult(shift));
  const auto camera = makeCamera(64);
  const auto deformed = render::renderDeformed(scene, camera, view(), kBackground);
  // Moving the object by t looks the same as moving the camera by -t.
  Eigen::Isometry3d moved = view();
  moved.translation() -= shift;
  const auto expected = nerf::renderImage(model, camera, moved, kBackground);
  const auto unmoved = nerf::renderImage(model, camera, view(), kBackground);
  const Eigen::Vector2d c_def = opacityCentroid(deformed.opacity), c_exp = opacityCentroid(expected.opacity);
  const Eigen::Vector2d c_rest = opacityCentroid(unmoved.opacity);
  EXPECT_GT((c_exp - c_rest).norm(), 3.0) << "the shift should move the image by several pixels";
  EXPECT_LT((c_def - c_exp).norm(), 1.0) << "deformed centroid " << c_def.transpose() << " vs shifted "
                                         << c_exp.transpose();
  EXPECT_GE(psnr(expected.color, deformed.color), 30.0);
}

TEST(DeformedRenderer, RotatedDirectionsStayUnitAndMatchForRigidTranslation) {
  const nerf::NerfModel model = makeModel();
  render::DeformedRenderConfig config;
  config.rotate_directions = false;
  const render::DeformedScene plain(model, makeResult(Eigen::Vector3d(0.05, 0, 0)), config);
  const render::DeformedScene rotated(model, makeResult(Eigen::Vector3d(0.05, 0, 0)));
  const auto camera = makeCamera(32);
  const auto a = render::renderDeformed(plain, camera, view(), kBackground);
  const auto b = render::renderDeformed(rotated, camera, view(), kBackground);
  EXPECT_GE(psnr(a.color, b.color), 50.0) << "a translation has no rotation";
}

TEST(DeformedRenderer, LocateMapsDeformedPointsBackLinearly) {
  core::ResultField result = makeResult(Eigen::Vector3d::Zero());
  // Affine deformation x = A X + c is reproduced exactly by linear tetrahedra.
  Eigen::Matrix3d a;
  a << 1.1, 0.2, 0.0, -0.1, 0.9, 0.05, 0.0, 0.1, 1.2;
  const Eigen::Vector3d c(0.01, -0.02, 0.03);
  for (std::size_t i = 0; i < result.size(); ++i) {
    result.displacements[i] = a * result.positions[i] + c - result.positions[i];
  }
  const render::TetEmbedding emb(result);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> in(0.32, 0.68);
  for (int k = 0; k < 200; ++k) {
    const Eigen::Vector3d rest(in(rng), in(rng), in(rng));
    const Eigen::Vector3d x = a * rest + c;
    const float xf[3] = {static_cast<float>(x.x()), static_cast<float>(x.y()), static_cast<float>(x.z())};
    const render::RestPoint rp = emb.locate(xf);
    ASSERT_GE(rp.tet, 0) << "point " << x.transpose() << " is inside the deformed body";
    for (int d = 0; d < 3; ++d) EXPECT_NEAR(rp.rest[d], rest[d], 1e-4);
  }
  const float far[3] = {3.0f, 3.0f, 3.0f};
  EXPECT_LT(emb.locate(far).tet, 0);
}

TEST(DeformedRenderer, RefusesResultsThatDoNotFitTheBody) {
  const nerf::NerfModel model = makeModel();
  auto expectError = [&](const core::ResultField& result, const std::string& needle,
                         const render::DeformedRenderConfig& config = {}) {
    try {
      render::DeformedScene scene(model, result, config);
      ADD_FAILURE() << "expected an error mentioning '" << needle << "'";
    } catch (const core::Error& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  expectError(core::ResultField(), "no particles");

  core::ResultField nan = makeResult(Eigen::Vector3d::Zero());
  nan.displacements[5].y() = std::numeric_limits<double>::quiet_NaN();
  expectError(nan, "particle 5 is not finite");

  core::ResultField outside = makeResult(Eigen::Vector3d::Zero());
  for (auto& p : outside.positions) p += Eigen::Vector3d(5, 0, 0);
  expectError(outside, "outside the NeRF's box");

  core::ResultField elsewhere = makeResult(Eigen::Vector3d::Zero());
  for (auto& p : elsewhere.positions) p = 0.25 * (p - Eigen::Vector3d::Constant(0.27));  // corner, empty
  expectError(elsewhere, "where the NeRF has density");

  render::DeformedRenderConfig counted;
  counted.expected_particles = 100;
  expectError(makeResult(Eigen::Vector3d::Zero()), "but the body has 100", counted);

  core::ResultField flat;
  for (int i = 0; i < 50; ++i) {
    flat.positions.emplace_back(0.4 + 0.005 * (i % 7), 0.4 + 0.005 * (i / 7), 0.5);
    flat.displacements.emplace_back(0, 0, 0);
    flat.von_mises.push_back(0);
  }
  expectError(flat, "coplanar");
}
