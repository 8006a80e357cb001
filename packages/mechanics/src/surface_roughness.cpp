#include "surface_roughness.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <unordered_map>
#include <vector>

namespace demnerf::mechanics {
namespace {

constexpr double kSameFace = 0.866;  // cos 30 degrees: neighbours on the same face
constexpr std::size_t kSampled = 4000;  // surface particles whose scatter is measured
constexpr int kMinNeighbours = 10;   // a quadric (6 coefficients) through fewer says little about the scatter

using Key = long long;

Key bucketKey(const Eigen::Vector3d& x, double size) {
  const auto index = [size](double v) { return static_cast<Key>(std::floor(v / size)) & 0x1fffff; };
  return (index(x.x()) << 42) | (index(x.y()) << 21) | index(x.z());
}

// The RMS distance of `points` from their least-squares quadric height field over their plane
// (the covariance's two largest axes): a smoothly curved surface (a cylinder, a sphere) is fitted
// exactly to second order and reads as smooth; bumps narrower than the neighbourhood remain.
double quadricScatter(const std::vector<Eigen::Vector3d>& points, double radius) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : points) mean += p;
  mean /= static_cast<double>(points.size());
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& p : points) covariance += (p - mean) * (p - mean).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen;
  eigen.computeDirect(covariance);
  const Eigen::Matrix3d axes = eigen.eigenvectors();  // column 0: the plane's normal
  // Normal equations of the fit in coordinates scaled by the radius (a well-conditioned 6 x 6).
  Eigen::Matrix<double, 6, 6> AtA = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> Ath = Eigen::Matrix<double, 6, 1>::Zero();
  double hh = 0.0;
  for (const Eigen::Vector3d& p : points) {
    const Eigen::Vector3d local = axes.transpose() * (p - mean) / radius;
    const double u = local(1), v = local(2);
    Eigen::Matrix<double, 6, 1> row;
    row << 1.0, u, v, u * u, u * v, v * v;
    AtA += row * row.transpose();
    Ath += row * local(0);
    hh += local(0) * local(0);
  }
  const Eigen::Matrix<double, 6, 1> fit = AtA.ldlt().solve(Ath);
  // |A fit - h|^2 = h.h - 2 fit.A^T h + fit.A^T A fit, which is h.h - fit.A^T h at the solution.
  const double residual = std::max(hh - fit.dot(Ath), 0.0);
  return radius * std::sqrt(residual / static_cast<double>(points.size()));
}

double median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const auto middle = values.begin() + static_cast<long>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

}  // namespace

double surfaceParticleSpacing(const core::ParticleCloud& cloud) {
  std::vector<double> areas;
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (i < cloud.areas.size() && cloud.areas[i] > 0) areas.push_back(cloud.areas[i]);
  return std::sqrt(median(std::move(areas)));
}

double surfaceRoughness(const core::ParticleCloud& cloud, double radius) {
  if (!(radius > 0) || cloud.normals.size() != cloud.size() || cloud.areas.size() != cloud.size()) return 0.0;
  std::vector<std::size_t> surface;
  std::unordered_map<Key, std::vector<std::size_t>> buckets;
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (cloud.isSurface(i) && cloud.normals[i].squaredNorm() > 0) {
      surface.push_back(i);
      buckets[bucketKey(cloud.positions[i], radius)].push_back(i);
    }
  std::vector<double> scatter;
  std::vector<Eigen::Vector3d> near;
  // The median needs a sample, not every particle: at most kSampled of them, evenly strided.
  const std::size_t stride = std::max<std::size_t>(1, surface.size() / kSampled);
  for (std::size_t s = 0; s < surface.size(); s += stride) {
    const std::size_t i = surface[s];
    const Eigen::Vector3d& x = cloud.positions[i];
    const Eigen::Vector3d n = cloud.normals[i].normalized();
    near.clear();
    for (int d = 0; d < 27; ++d) {
      const Eigen::Vector3d probe = x + radius * Eigen::Vector3d(d % 3 - 1, (d / 3) % 3 - 1, d / 9 - 1);
      const auto found = buckets.find(bucketKey(probe, radius));
      if (found == buckets.end()) continue;
      for (std::size_t j : found->second)
        if ((cloud.positions[j] - x).norm() <= radius && n.dot(cloud.normals[j].normalized()) >= kSameFace)
          near.push_back(cloud.positions[j]);
    }
    if (static_cast<int>(near.size()) >= kMinNeighbours) scatter.push_back(quadricScatter(near, radius));
  }
  return median(std::move(scatter));
}

}  // namespace demnerf::mechanics
