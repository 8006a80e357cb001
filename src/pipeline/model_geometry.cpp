#include "pipeline/model_geometry.hpp"

#include <algorithm>

#include "demnerf/geometry/density_sampling.hpp"

namespace dem_nerf {

demnerf::geometry::DensityGrid densityGridOf(const demnerf::nerf::NerfModel& model, int resolution) {
  const demnerf::nerf::Box box = model.bounds();
  const Eigen::AlignedBox3d aabb(Eigen::Vector3d(box.min[0], box.min[1], box.min[2]),
                                 Eigen::Vector3d(box.max[0], box.max[1], box.max[2]));
  return demnerf::geometry::sampleDensityGrid(
      [&model](const float* points, std::int64_t n, float* sigma) { model.field().density(points, n, sigma); }, aabb,
      resolution);
}

demnerf::geometry::DensityGrid densityGridInBox(const demnerf::nerf::NerfModel& model, const Eigen::AlignedBox3d& box,
                                                int resolution) {
  return demnerf::geometry::sampleDensityInBox(
      [&model](const float* points, std::int64_t n, float* sigma) { model.field().density(points, n, sigma); }, box,
      resolution);
}

demnerf::geometry::MeshExtractionResult extractSurface(const demnerf::nerf::NerfModel& model,
                                                       const SurfaceConfig& config,
                                                       demnerf::geometry::IsolationReport* pieces) {
  if (!config.box) return demnerf::geometry::extractMesh(densityGridOf(model, config.resolution), config.mesh);
  return demnerf::geometry::isolateObject(densityGridInBox(model, *config.box, config.resolution), config.mesh,
                                          config.isolation, pieces);
}

void colourFromModel(const demnerf::nerf::NerfModel& model, demnerf::core::ParticleCloud* cloud) {
  const std::size_t n = cloud->size();
  std::vector<float> points(3 * n), directions(3 * n), sigma(n), rgb(3 * n);
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d view = cloud->isSurface(i) ? Eigen::Vector3d(-cloud->normals[i]) : Eigen::Vector3d(0, 0, -1);
    for (int a = 0; a < 3; ++a) {
      points[3 * i + a] = static_cast<float>(cloud->positions[i][a]);
      directions[3 * i + a] = static_cast<float>(view[a]);
    }
  }
  model.field().query(points.data(), directions.data(), static_cast<std::int64_t>(n), sigma.data(), rgb.data());
  for (std::size_t i = 0; i < n; ++i) {
    for (int c = 0; c < 3; ++c) {
      const float v = std::clamp(rgb[3 * i + c], 0.0f, 1.0f);
      cloud->colors[i][c] = static_cast<std::uint8_t>(v * 255.0f + 0.5f);
    }
  }
}

demnerf::core::ParticleCloud particlesFromModel(const demnerf::nerf::NerfModel& model, const SurfaceConfig& surface,
                                                demnerf::geometry::SamplerConfig sampling,
                                                demnerf::core::TriangleMesh* mesh_out) {
  const demnerf::core::TriangleMesh mesh = extractSurface(model, surface).mesh;
  if (sampling.spacing <= 0.0) {
    Eigen::AlignedBox3d box;
    for (const auto& v : mesh.vertices) box.extend(v);
    sampling.spacing = box.diagonal().norm() / 40.0;
  }
  demnerf::core::ParticleCloud cloud = demnerf::geometry::sampleParticles(mesh, sampling, nullptr);
  colourFromModel(model, &cloud);
  if (mesh_out != nullptr) *mesh_out = mesh;
  return cloud;
}

}  // namespace dem_nerf
