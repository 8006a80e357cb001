// The density prior (train.density_prior): space that no training ray confirms, behind what the
// cameras see, is emptied, while what they see is fit as before. Without it, training rays that
// stop at 1 % transmittance leave the density behind the visible surfaces as it was, and a
// density-level extraction of a real capture (the fox) fills its box with it.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "demnerf/core/error.hpp"
#include "demnerf/nerf/evaluate.hpp"
#include "demnerf/nerf/trainer.hpp"
#include "ball_view.hpp"

namespace demnerf::nerf {
namespace {

/// Views from a 30 degree cone around +x only: the far side of the ball and the box behind it
/// (x < -test::kBallRadius near the axis) are seen by no camera.
std::vector<core::Frame> frontViews(int count, double phase) {
  std::vector<core::Frame> frames;
  for (int i = 0; i < count; ++i) {
    const double tilt = 0.5 * (i + 0.5) / count, turn = 2.399963 * i + phase;
    const Eigen::Vector3d dir(std::cos(tilt), std::sin(tilt) * std::cos(turn), std::sin(tilt) * std::sin(turn));
    frames.push_back(test::ballViewFrom(2.2 * dir, 32));
  }
  return frames;
}

/// The fox's training settings on a small field: rays stop, and gradients end, at 1 % light.
NerfConfig stoppingConfig(double prior) {
  NerfConfig c = test::smallBallConfig();
  c.train.min_rays = 256;
  c.train.gradient_min_transmittance = 0.01;
  c.march.min_transmittance = 0.01;
  c.occupancy.warmup_steps = 64;  // the prior starts after the warm-up
  c.train.density_prior = prior;
  return c;
}

struct Outcome {
  double hidden_sigma, front_depth, psnr;
};

Outcome trainAndProbe(double prior, const std::vector<core::Frame>& train, const std::vector<core::Frame>& test) {
  Box box;
  for (int a = 0; a < 3; ++a) box.min[a] = -0.6f, box.max[a] = 0.6f;
  Trainer trainer(stoppingConfig(prior), box, 1.0);
  trainer.addFrames(train);
  trainer.train({0.0, 200}, {}, false);
  // Mean density inside the ball, 0.08-0.3 behind its front surface (the views' rays run out of
  // light before: no ray confirms it), and the optical depth of the ball's front half along
  // lines through it (what the views see: opaque).
  std::vector<float> hidden, front;
  const int steps = 60;
  for (int j = -4; j <= 4; ++j)
    for (int k = -4; k <= 4; ++k) {
      const float y = 0.04f * j, z = 0.04f * k;
      for (float x : {0.25f, 0.2f, 0.15f, 0.1f}) hidden.insert(hidden.end(), {x, y, z});
      for (int s = 0; s < steps; ++s) front.insert(front.end(), {0.6f - 0.6f * (s + 0.5f) / steps, y, z});
    }
  const auto density = [&](const std::vector<float>& points) {
    std::vector<float> sigma(points.size() / 3);
    trainer.model().field().density(points.data(), static_cast<std::int64_t>(sigma.size()), sigma.data());
    return sigma;
  };
  double hidden_sum = 0.0, least_depth = 1e30;
  for (float s : density(hidden)) hidden_sum += s;
  const std::vector<float> along = density(front);
  for (std::size_t line = 0; line < along.size() / steps; ++line) {
    double depth = 0.0;
    for (int s = 0; s < steps; ++s) depth += along[line * steps + s] * 0.6 / steps;
    least_depth = std::min(least_depth, depth);
  }
  return {hidden_sum / static_cast<double>(hidden.size() / 3), least_depth, evaluate(trainer.model(), test, false).psnr};
}

TEST(DensityPrior, EmptiesTheSpaceNoRayConfirmsAndKeepsWhatTheViewsSee) {
  const std::vector<core::Frame> train = frontViews(16, 0.0), test = frontViews(3, 1.0);
  const Outcome without = trainAndProbe(0.0, train, test), with = trainAndProbe(1e-2, train, test);
  std::printf("behind the ball: mean density %.2f without the prior, %.3f with; least optical depth of its front "
              "half %.1f / %.1f; "
              "held-out %.2f / %.2f dB\n",
              without.hidden_sigma, with.hidden_sigma, without.front_depth, with.front_depth, without.psnr, with.psnr);
  EXPECT_GT(without.hidden_sigma, 10.0);  // the scene shows the problem: density no ray fit
  EXPECT_LT(with.hidden_sigma, 0.3 * without.hidden_sigma);
  EXPECT_GT(with.front_depth, 2.3);  // the ball stays opaque (> 90 %) where the views see it
  EXPECT_GT(with.psnr, without.psnr - 1.5);
}

TEST(DensityPrior, ConfigKeysAndLimits) {
  const NerfConfig c = parseNerfConfig("train: {density_prior: 1.0e-3, density_prior_per_ray: 3}");
  EXPECT_DOUBLE_EQ(c.train.density_prior, 1e-3);
  EXPECT_EQ(c.train.density_prior_per_ray, 3);
  EXPECT_DOUBLE_EQ(NerfConfig{}.train.density_prior, 0.0);  // off unless a config asks for it
  EXPECT_THROW(parseNerfConfig("train: {density_prior: -1.0}"), core::Error);
  EXPECT_THROW(parseNerfConfig("train: {density_prior_per_ray: 5}"), core::Error);
}

}  // namespace
}  // namespace demnerf::nerf
