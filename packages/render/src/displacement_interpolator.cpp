#include "demnerf/render/displacement_interpolator.hpp"

#include <CGAL/Orthogonal_k_neighbor_search.h>
#include <CGAL/Search_traits_3.h>
#include <CGAL/Search_traits_adapter.h>
#include <CGAL/Simple_cartesian.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>

#include "demnerf/core/error.hpp"

namespace demnerf::render {
namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using Point = Kernel::Point_3;

// The kd-tree stores particle indices; this map gives their positions.
struct IndexToPoint {
  using key_type = std::size_t;
  using value_type = Point;
  using reference = const Point&;
  using category = boost::readable_property_map_tag;
  const std::vector<Point>* points = nullptr;
  friend reference get(const IndexToPoint& map, key_type index) { return (*map.points)[index]; }
};

using Traits = CGAL::Search_traits_adapter<std::size_t, IndexToPoint, CGAL::Search_traits_3<Kernel>>;
using Search = CGAL::Orthogonal_k_neighbor_search<Traits>;
using Tree = Search::Tree;
using Distance = Search::Distance;

std::string format(const Eigen::Vector3d& v) {
  std::ostringstream out;
  out << "(" << v.x() << ", " << v.y() << ", " << v.z() << ")";
  return out.str();
}

}  // namespace

struct DisplacementInterpolator::Impl {
  std::vector<Point> points;
  std::vector<Eigen::Vector3d> positions;
  std::vector<Eigen::Vector3d> displacements;
  IndexToPoint map;
  std::unique_ptr<Tree> tree;

  // Indices and squared distances of the k nearest particles, nearest first.
  std::vector<std::pair<std::size_t, double>> nearest(const Eigen::Vector3d& x, int k) const {
    const Search search(*tree, Point(x.x(), x.y(), x.z()), static_cast<unsigned>(k), 0.0, true, Distance(map));
    std::vector<std::pair<std::size_t, double>> result;
    for (const auto& entry : search) result.emplace_back(entry.first, entry.second);
    return result;
  }
};

DisplacementInterpolator::DisplacementInterpolator(const std::vector<Eigen::Vector3d>& positions,
                                                   const std::vector<Eigen::Vector3d>& displacements,
                                                   const InterpolatorConfig& config)
    : impl_(std::make_unique<Impl>()), config_(config) {
  if (positions.size() != displacements.size()) {
    throw core::Error("displacement field: " + std::to_string(positions.size()) + " positions but " +
                      std::to_string(displacements.size()) + " displacements");
  }
  if (config.neighbours < 4) {
    throw core::Error("displacement field: a linear fit needs at least 4 neighbours, got " +
                      std::to_string(config.neighbours));
  }
  if (positions.size() < static_cast<std::size_t>(config.neighbours)) {
    throw core::Error("displacement field: " + std::to_string(positions.size()) +
                      " particles are too few (need at least " + std::to_string(config.neighbours) + ")");
  }
  for (std::size_t i = 0; i < positions.size(); ++i) {
    if (!positions[i].allFinite() || !displacements[i].allFinite()) {
      throw core::Error("displacement field: particle " + std::to_string(i) + " has a non-finite value");
    }
  }
  impl_->positions = positions;
  impl_->displacements = displacements;
  impl_->points.reserve(positions.size());
  for (const auto& p : positions) impl_->points.emplace_back(p.x(), p.y(), p.z());
  impl_->map.points = &impl_->points;
  std::vector<std::size_t> indices(positions.size());
  for (std::size_t i = 0; i < indices.size(); ++i) indices[i] = i;
  impl_->tree = std::make_unique<Tree>(indices.begin(), indices.end(), Tree::Splitter(), Traits(impl_->map));
  impl_->tree->build();
  // Typical spacing: median distance from a particle to its nearest other particle.
  std::vector<double> gaps;
  const std::size_t stride = std::max<std::size_t>(1, positions.size() / 2000);
  for (std::size_t i = 0; i < positions.size(); i += stride) {
    const auto near = impl_->nearest(positions[i], 2);
    gaps.push_back(std::sqrt(near.back().second));
  }
  std::nth_element(gaps.begin(), gaps.begin() + gaps.size() / 2, gaps.end());
  spacing_ = gaps[gaps.size() / 2];
  if (!(spacing_ > 0)) {
    throw core::Error("displacement field: particles coincide (median nearest-neighbour distance is 0)");
  }
}

DisplacementInterpolator::~DisplacementInterpolator() = default;

double DisplacementInterpolator::distanceToNearest(const Eigen::Vector3d& point) const {
  return std::sqrt(impl_->nearest(point, 1).front().second);
}

Eigen::Vector3d DisplacementInterpolator::at(const Eigen::Vector3d& x) const {
  const auto near = impl_->nearest(x, config_.neighbours);
  // Support radius just beyond the farthest neighbour so every neighbour has a positive weight.
  const double h2 = near.back().second * 1.21 + 1e-30;
  std::vector<double> weights;
  weights.reserve(near.size());
  double total = 0.0;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& [index, d2] : near) {
    const double q = 1.0 - d2 / h2;
    weights.push_back(q * q);
    total += weights.back();
    centroid += weights.back() * impl_->positions[index];
    mean += weights.back() * impl_->displacements[index];
  }
  if (!(total > 0)) return impl_->displacements[near.front().first];
  centroid /= total;
  mean /= total;
  // Fit u = mean + B (X - centroid): centring at the weighted centroid decouples the mean from
  // the gradient, which solves covariance * B^T = cross.
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d cross = Eigen::Matrix3d::Zero();
  for (std::size_t n = 0; n < near.size(); ++n) {
    const Eigen::Vector3d d = impl_->positions[near[n].first] - centroid;
    covariance += weights[n] * d * d.transpose();
    cross += weights[n] * d * (impl_->displacements[near[n].first] - mean).transpose();
  }
  // Pseudo-inverse: directions without spread (a one-layer membrane, a line of particles) get
  // no gradient instead of a wild one; a linear field is reproduced exactly otherwise.
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(covariance);
  const Eigen::Vector3d values = eigen.eigenvalues();
  const double cutoff = config_.gradient_cutoff * values.maxCoeff();
  Eigen::Vector3d inverse = Eigen::Vector3d::Zero();
  for (int i = 0; i < 3; ++i) inverse[i] = values[i] > cutoff && values[i] > 0 ? 1.0 / values[i] : 0.0;
  const Eigen::Matrix3d gradient_transposed =
      eigen.eigenvectors() * inverse.asDiagonal() * eigen.eigenvectors().transpose() * cross;
  const Eigen::Vector3d value = mean + gradient_transposed.transpose() * (x - centroid);
  return value.allFinite() ? value : impl_->displacements[near.front().first];
}

std::vector<Eigen::Vector3d> DisplacementInterpolator::at(const std::vector<Eigen::Vector3d>& points) const {
  std::vector<Eigen::Vector3d> values;
  values.reserve(points.size());
  for (const auto& p : points) values.push_back(at(p));
  return values;
}

double DisplacementInterpolator::checkCovers(const std::vector<Eigen::Vector3d>& points,
                                             const std::string& what) const {
  double worst = 0.0;
  Eigen::Vector3d worst_point = Eigen::Vector3d::Zero();
  for (const auto& p : points) {
    const double d = distanceToNearest(p);
    if (d > worst) {
      worst = d;
      worst_point = p;
    }
  }
  const double limit = config_.coverage_factor * spacing_;
  if (worst > limit) {
    std::ostringstream message;
    message << "the displacement field does not cover " << what << ": the point " << format(worst_point)
            << " is " << worst << " m from the nearest particle, more than " << config_.coverage_factor
            << " x the particle spacing " << spacing_ << " m (is the result for another body or frame?)";
    throw core::Error(message.str());
  }
  return worst;
}

core::TriangleMesh deformMesh(const core::TriangleMesh& rest, const DisplacementInterpolator& field) {
  core::TriangleMesh deformed = rest;
  const auto displacement = field.at(rest.vertices);
  for (std::size_t i = 0; i < deformed.vertices.size(); ++i) deformed.vertices[i] += displacement[i];
  return deformed;
}

}  // namespace demnerf::render
