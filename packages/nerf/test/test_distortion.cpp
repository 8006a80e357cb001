// The distortion term (train.distortion, distortion.hpp): its running sums give mip-NeRF 360's
// loss and a sigma gradient that matches finite differences of the loss's definition; at weight
// 0 training takes none of its code; a positive weight changes training and sharpens the edge.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "demnerf/core/error.hpp"
#include "demnerf/nerf/distortion.hpp"
#include "demnerf/nerf/trainer.hpp"
#include "ball_view.hpp"

namespace demnerf::nerf {
namespace {

struct SmallRay {
  std::vector<double> sigma, t, dt;  // midpoints t, lengths dt, front to back
};

/// Eight samples with gaps (as after skipped empty cells), lengths 0.02-0.06, starting at 1.3.
SmallRay smallRay() {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  SmallRay r;
  double edge = 1.3;
  for (int i = 0; i < 8; ++i) {
    const double dt = 0.02 + 0.04 * u(rng);
    r.sigma.push_back(30.0 * u(rng));
    r.t.push_back(edge + 0.5 * dt);
    r.dt.push_back(dt);
    edge += dt + (i == 3 ? 0.1 : 0.0);
  }
  return r;
}

/// The loss from its definition (double, O(n^2)), distances over `unit`.
double referenceLoss(const SmallRay& r, const std::vector<double>& sigma, double unit) {
  std::vector<double> w;
  double transmittance = 1.0;
  for (std::size_t i = 0; i < sigma.size(); ++i) {
    const double alpha = 1.0 - std::exp(-sigma[i] * r.dt[i]);
    w.push_back(transmittance * alpha);
    transmittance *= 1.0 - alpha;
  }
  double loss = 0.0;
  for (std::size_t i = 0; i < w.size(); ++i) {
    for (std::size_t j = 0; j < w.size(); ++j) loss += w[i] * w[j] * std::fabs(r.t[i] - r.t[j]) / unit;
    loss += w[i] * w[i] * r.dt[i] / unit / 3.0;
  }
  return loss;
}

TEST(Distortion, LossAndSigmaGradientMatchTheDefinition) {
  const SmallRay r = smallRay();
  const double unit = 0.7;
  const float inv_unit = static_cast<float>(1.0 / unit);
  const int n = static_cast<int>(r.sigma.size());
  // Forward as the trainer does it: RayAccum's weights, one record per sample.
  DistortionAccum total;
  std::vector<float> upto(4 * n), w(n), t_next(n);
  float transmittance = 1.0f;
  for (int i = 0; i < n; ++i) {
    const float alpha = 1.0f - std::exp(-static_cast<float>(r.sigma[i] * r.dt[i]));
    w[i] = transmittance * alpha;
    transmittance *= 1.0f - alpha;
    t_next[i] = transmittance;
    total.add(w[i], static_cast<float>(r.t[i]), static_cast<float>(r.dt[i]), inv_unit, upto.data() + 4 * i);
  }
  const double reference = referenceLoss(r, r.sigma, unit);
  EXPECT_GT(reference, 1e-3);
  EXPECT_NEAR(total.loss(), reference, 1e-5 * reference);
  for (int i = 0; i < n; ++i) {
    const double eps = 1e-4;
    std::vector<double> plus = r.sigma, minus = r.sigma;
    plus[i] += eps;
    minus[i] -= eps;
    const double fd = (referenceLoss(r, plus, unit) - referenceLoss(r, minus, unit)) / (2 * eps);
    const double ours = distortionSigmaGradient(total, upto.data() + 4 * i, w[i], static_cast<float>(r.dt[i]),
                                                t_next[i], inv_unit) * r.dt[i];
    EXPECT_NEAR(ours, fd, 1e-6 + 1e-3 * std::fabs(fd)) << "sample " << i;
  }
}

// The loss depends on distances along the ray only, not on where the ray starts.
TEST(Distortion, DoesNotDependOnTheRaysOrigin) {
  const SmallRay r = smallRay();
  auto lossFrom = [&](double shift) {
    DistortionAccum a;
    float upto[4];
    for (std::size_t i = 0; i < r.t.size(); ++i)
      a.add(0.1f, static_cast<float>(r.t[i] + shift), static_cast<float>(r.dt[i]), 1.0f, upto);
    return a.loss();
  };
  EXPECT_NEAR(lossFrom(25.0), lossFrom(0.0), 1e-4 * lossFrom(0.0));
}

/// Views of test::ballViewFrom's ball from all round.
std::vector<core::Frame> ballViews(int count, int size) {
  std::vector<core::Frame> frames;
  for (int i = 0; i < count; ++i) {
    const double z = 1.0 - 2.0 * (i + 0.5) / count, turn = 2.399963 * i, rho = std::sqrt(1.0 - z * z);
    frames.push_back(test::ballViewFrom(2.0 * Eigen::Vector3d(rho * std::cos(turn), rho * std::sin(turn), z), size));
  }
  return frames;
}

NerfConfig smallConfig(double distortion) {
  NerfConfig c = test::smallBallConfig();
  c.train.distortion = distortion;
  return c;
}

struct Trained {
  std::vector<float> table;
  double edge_width;  ///< mean distance over which radial lines go from 10 % to 90 % opaque
};

Trained trainBall(double distortion, const std::vector<core::Frame>& views, int steps) {
  Box box;
  for (int a = 0; a < 3; ++a) box.min[a] = -0.6f, box.max[a] = 0.6f;
  Trainer trainer(smallConfig(distortion), box, 1.0);
  trainer.addFrames(views);
  trainer.setBudget({0.0, steps});
  trainer.step(steps);
  // Radial lines from 0.58 in to 0.2 from the centre, in 26 directions.
  const int samples = 400;
  const float step = 0.38f / samples;
  std::vector<float> points;
  int lines = 0;
  for (int x = -1; x <= 1; ++x)
    for (int y = -1; y <= 1; ++y)
      for (int z = -1; z <= 1; ++z) {
        if (x == 0 && y == 0 && z == 0) continue;
        const float norm = std::sqrt(static_cast<float>(x * x + y * y + z * z));
        for (int s = 0; s < samples; ++s) {
          const float radius = 0.58f - step * (s + 0.5f);
          points.insert(points.end(), {radius * x / norm, radius * y / norm, radius * z / norm});
        }
        ++lines;
      }
  std::vector<float> sigma(points.size() / 3);
  trainer.model().field().density(points.data(), static_cast<std::int64_t>(sigma.size()), sigma.data());
  double width = 0.0;
  for (int l = 0; l < lines; ++l) {
    double depth = 0.0, at10 = -1.0, at90 = -1.0;
    for (int s = 0; s < samples; ++s) {
      depth += sigma[l * samples + s] * step;
      const double opacity = 1.0 - std::exp(-depth);
      if (at10 < 0 && opacity > 0.1) at10 = s * step;
      if (at90 < 0 && opacity > 0.9) at90 = s * step;
    }
    width += (at90 < 0 ? samples * step : at90) - (at10 < 0 ? 0.0 : at10);
  }
  return {trainer.model().ngp().table(), width / lines};
}

// Weight 0 is the trainer as it was: no record, no gradient, the same bits as a config that
// never names the key. A positive weight trains differently and gives a sharper density edge.
TEST(Distortion, ZeroIsOffAndAPositiveWeightSharpensTheEdge) {
  const std::vector<core::Frame> views = ballViews(24, 32);
  NerfConfig named = parseNerfConfig("train: {distortion: 0.0}");
  EXPECT_DOUBLE_EQ(named.train.distortion, NerfConfig{}.train.distortion);
  EXPECT_THROW(parseNerfConfig("train: {distortion: -1.0}"), core::Error);
  const Trained off = trainBall(0.0, views, 150), on = trainBall(0.1, views, 150);
  std::printf("edge width (10-90 %% opaque along radial lines): %.4f without the term, %.4f with\n", off.edge_width,
              on.edge_width);
  EXPECT_NE(off.table, on.table);
  EXPECT_LT(on.edge_width, off.edge_width);
}

}  // namespace
}  // namespace demnerf::nerf
