// The paper's "particle sampling methods" figure: random, Poisson-disk and uniform-grid particles
// in the same mesh. Top row: the whole cloud seen from the side (orthographic, depth-shaded);
// bottom row: a slab one spacing thick through the middle, interior particles blue and surface
// particles orange, which shows clusters (random), the dense boundary layer (Poisson) and the
// lattice (grid).
//   geometry_samplers_figure [--mesh spot.obj] [--fraction 0.02] [--out docs/samplers.png]

#include <algorithm>
#include <cmath>
#include <iostream>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "demnerf/core/error.hpp"
#include "demnerf/geometry/mesh_analysis.hpp"
#include "demnerf/geometry/particle_sampler.hpp"

using namespace demnerf;

namespace {

constexpr int kPanel = 420;  // pixels per panel side

struct View {
  Eigen::Matrix3d rotation;  // world -> view (x right, y up, z towards the viewer)
  Eigen::Vector3d centre;
  double scale;  // pixels per metre
};

cv::Point2f project(const View& view, const Eigen::Vector3d& p, double* depth) {
  const Eigen::Vector3d q = view.rotation * (p - view.centre);
  *depth = q.z();
  return {static_cast<float>(kPanel / 2 + q.x() * view.scale), static_cast<float>(kPanel / 2 + 12 - q.y() * view.scale)};
}

// Centre and scale a view so the mesh fills most of a panel.
void fit(View* view, const core::TriangleMesh& mesh) {
  Eigen::AlignedBox3d box;
  for (const auto& v : mesh.vertices) box.extend(Eigen::Vector3d(view->rotation * v));
  view->centre = view->rotation.transpose() * box.center();
  view->scale = 0.86 * kPanel / std::max(box.sizes().x(), box.sizes().y());
}

void drawCloud(cv::Mat& panel, const View& view, const core::ParticleCloud& cloud, bool slab_only, double slab,
               double radius_px) {
  struct Dot {
    double depth;
    cv::Point2f at;
    bool surface;
  };
  std::vector<Dot> dots;
  double near = -1e9, far = 1e9;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    double depth = 0;
    const cv::Point2f at = project(view, cloud.positions[i], &depth);
    // Whole cloud: the surface particles show the body; slab: everything near the middle plane.
    // The slab is offset by a fifth of its width so that a grid layer never sits on its edge.
    if (slab_only ? std::abs(depth - 0.2 * slab) > 0.5 * slab : !cloud.isSurface(i)) continue;
    dots.push_back({depth, at, cloud.isSurface(i)});
    near = std::max(near, depth);
    far = std::min(far, depth);
  }
  std::sort(dots.begin(), dots.end(), [](const Dot& a, const Dot& b) { return a.depth < b.depth; });
  const int shift = 4;  // sub-pixel positions for anti-aliased circles
  for (const Dot& dot : dots) {
    // Nearer particles brighter; surface orange, interior blue (BGR).
    const double t = slab_only ? 1.0 : 0.35 + 0.65 * (dot.depth - far) / std::max(near - far, 1e-9);
    const cv::Vec3d base = dot.surface ? cv::Vec3d(40, 140, 245) : cv::Vec3d(200, 110, 40);
    const cv::Scalar colour(base[0] * t, base[1] * t, base[2] * t);
    const cv::Point centre(cvRound(dot.at.x * (1 << shift)), cvRound(dot.at.y * (1 << shift)));
    cv::circle(panel, centre, cvRound(radius_px * (1 << shift)), colour, cv::FILLED, cv::LINE_AA, shift);
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::string mesh_path = std::string(DEMNERF_SHARED_DIR) + "/data/meshes/spot.obj";
  std::string out_path = std::string(DEMNERF_SOURCE_DIR) + "/docs/samplers.png";
  double fraction = 0.02;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string key = argv[i];
    if (key == "--mesh") mesh_path = argv[i + 1];
    else if (key == "--out") out_path = argv[i + 1];
    else if (key == "--fraction") fraction = std::stod(argv[i + 1]);
    else {
      std::cerr << "unknown option " << key << "\n";
      return 2;
    }
  }
  try {
    const core::TriangleMesh mesh = core::readMesh(mesh_path);
    const geometry::MeshSummary summary = geometry::analyzeMesh(mesh);
    const double spacing = fraction * summary.diagonal();
    // Spot stands with +y up and faces +z. Top: three-quarter view from slightly above. Bottom:
    // straight from the side (+z), so the grid's slab shows its lattice.
    View view;
    view.rotation = (Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()) *
                     Eigen::AngleAxisd(-0.9, Eigen::Vector3d::UnitY())).toRotationMatrix();
    fit(&view, mesh);
    View side;
    side.rotation = Eigen::Matrix3d::Identity();
    fit(&side, mesh);
    // The slab is centred on the body's middle plane along the side view's axis.

    const geometry::SamplingMethod methods[] = {geometry::SamplingMethod::kRandom, geometry::SamplingMethod::kPoisson,
                                                geometry::SamplingMethod::kGrid};
    const char* titles[] = {"random", "Poisson disk", "uniform grid"};
    cv::Mat figure(2 * kPanel, 3 * kPanel, CV_8UC3, cv::Scalar(255, 255, 255));
    for (int m = 0; m < 3; ++m) {
      geometry::SamplerConfig config;
      config.method = methods[m];
      config.spacing = spacing;
      geometry::SamplingReport report;
      const core::ParticleCloud cloud = geometry::sampleParticles(mesh, config, &report);
      cv::Mat top = figure(cv::Rect(m * kPanel, 0, kPanel, kPanel));
      cv::Mat bottom = figure(cv::Rect(m * kPanel, kPanel, kPanel, kPanel));
      drawCloud(top, view, cloud, false, 0.0, 0.3 * spacing * view.scale);
      drawCloud(bottom, side, cloud, true, spacing, 0.25 * spacing * side.scale);
      const std::string label = std::string(titles[m]) + ": " + std::to_string(report.interior) + " interior + " +
                                std::to_string(report.surface) + " surface";
      cv::putText(top, label, {10, 22}, cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
      cv::putText(bottom, "side view, slab 1 spacing thick through the middle", {10, 22}, cv::FONT_HERSHEY_SIMPLEX, 0.45,
                  cv::Scalar(60, 60, 60), 1, cv::LINE_AA);
      std::cout << titles[m] << ": " << report.interior << " interior, " << report.surface << " surface\n";
    }
    cv::putText(figure, "spot.obj, spacing " + std::to_string(spacing).substr(0, 6) +
                    " (2% of the diagonal). Top: surface particles; bottom: blue interior, orange surface",
                {10, 2 * kPanel - 10}, cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(60, 60, 60), 1, cv::LINE_AA);
    if (!cv::imwrite(out_path, figure, {cv::IMWRITE_PNG_COMPRESSION, 9})) throw core::Error("cannot write " + out_path);
    std::cout << "wrote " << out_path << "\n";
  } catch (const std::exception& error) {
    std::cerr << "geometry_samplers_figure: " << error.what() << "\n";
    return 1;
  }
  return 0;
}
