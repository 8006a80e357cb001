// The checks and resizing of the particle cloud and result field (particle_cloud.hpp).

#include "demnerf/core/particle_cloud.hpp"

#include <cmath>
#include <string>

#include "demnerf/core/error.hpp"

namespace demnerf::core {
namespace {

void requireFinite(const std::vector<Eigen::Vector3d>& values, const char* what, const char* owner) {
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (!values[i].allFinite()) {
      throw Error(std::string(owner) + ": " + what + " of row " + std::to_string(i) + " is NaN or Inf");
    }
  }
}

}  // namespace

void ParticleCloud::resize(std::size_t n) {
  positions.resize(n, Eigen::Vector3d::Zero());
  volumes.resize(n, 0.0);
  normals.resize(n, Eigen::Vector3d::Zero());
  areas.resize(n, 0.0);
  colors.resize(n, {200, 200, 200});
}

void ParticleCloud::append(const Eigen::Vector3d& position, double volume, const Eigen::Vector3d& normal,
                           double area) {
  positions.push_back(position);
  volumes.push_back(volume);
  normals.push_back(normal);
  areas.push_back(area);
  colors.push_back({200, 200, 200});
}

void ParticleCloud::validate() const {
  const std::size_t n = positions.size();
  if (volumes.size() != n || normals.size() != n || areas.size() != n || colors.size() != n) {
    throw Error("particle cloud: field lengths differ (positions, volumes, normals, areas, colors)");
  }
  requireFinite(positions, "position", "particle cloud");
  requireFinite(normals, "normal", "particle cloud");
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(volumes[i]) || volumes[i] < 0 || !std::isfinite(areas[i]) || areas[i] < 0) {
      throw Error("particle cloud: volume/area of particle " + std::to_string(i) + " is negative, NaN or Inf");
    }
  }
}

void ResultField::resize(std::size_t n) {
  positions.resize(n, Eigen::Vector3d::Zero());
  displacements.resize(n, Eigen::Vector3d::Zero());
  von_mises.resize(n, 0.0);
}

void ResultField::validate() const {
  if (displacements.size() != positions.size() || von_mises.size() != positions.size()) {
    throw Error("result: field lengths differ (positions, displacements, von_mises)");
  }
  requireFinite(positions, "position", "result");
  requireFinite(displacements, "displacement", "result");
}

}  // namespace demnerf::core
