#include "mechanics_matrix_cases.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>

#include "demnerf/render/box_mesh.hpp"
#include "demnerf/render/scene_geometry.hpp"

namespace demnerf::bench {
namespace {

using Eigen::Vector3d;

std::string format(const char* pattern, double a, double b = 0, double c = 0) {
  char text[256];
  std::snprintf(text, sizeof text, pattern, a, b, c);
  return text;
}

// A box as the renderer's structured meshes make it: faces split so no edge is longer than
// max_edge (CGAL's facet criteria then see the same surface at any reference mesh size).
core::TriangleMesh box(const Vector3d& lo, const Vector3d& hi, double max_edge) {
  return render::meshBoxUnion({Eigen::AlignedBox3d(lo, hi)}, max_edge);
}

// Lateral stretch b of compressible Neo-Hookean (psi = mu/2 (I1 - 3) - mu ln J + lambda/2 ln^2 J)
// under uniaxial stretch s with stress-free sides: P_xx = (mu (b^2 - 1) + lambda ln(b^2 s)) / b = 0.
double lateralStretch(double youngs, double nu, double s) {
  const double mu = youngs / (2 * (1 + nu)), lambda = youngs * nu / ((1 + nu) * (1 - 2 * nu));
  double lo = 0.5, hi = 2.0;
  for (int i = 0; i < 200; ++i) {
    const double b = 0.5 * (lo + hi);
    (mu * (b * b - 1) + lambda * std::log(b * b * s) > 0 ? hi : lo) = b;
  }
  return 0.5 * (lo + hi);
}

MatrixCase tbar() {
  MatrixCase c{"tbar_twist", "tbar", 0.06, [] { return render::makeSceneObject(render::SceneKind::kTBar).mesh; }, {}, {}};
  c.probes = {{"front_right_patch", Vector3d(0.125, -0.0299, 0.27)}};
  c.check = [](const std::vector<Vector3d>& u) {
    // The YAML's torsion estimate: ~46 mm at the patch centres (slender-bar formula, +-30 %).
    const double m = u[0].norm();
    return Sanity{format("|u| at the front-right patch %.1f mm (torsion estimate ~46 mm)", 1e3 * m), m > 0.032 && m < 0.06};
  };
  return c;
}

MatrixCase cuboid() {
  MatrixCase c{"cuboid_twist", "cuboid", 0.1, [] { return render::makeSceneObject(render::SceneKind::kCuboid).mesh; }, {}, {}};
  c.probes = {{"end_edge_mid", Vector3d(0.1249, 0.0499, 0.0)}};
  c.check = [](const std::vector<Vector3d>& u) {
    // Rotation of the end face about x, seen at (y, z) = (0.05, 0): slender-bar estimate 0.40 rad, a short
    // clamped block twists less.
    const double angle = std::atan2(u[0].z(), 0.05 + u[0].y());
    return Sanity{format("end twist %.3f rad (slender-bar bound 0.40 rad; the short block twists less)", angle),
                  angle > 0.1 && angle < 0.45};
  };
  return c;
}

MatrixCase cantilever() {
  MatrixCase c{"cantilever_bending", "", 0.05,
               [] { return box(Vector3d(0, -0.025, -0.025), Vector3d(0.25, 0.025, 0.025), 0.01); }, {}, {}};
  c.probes = {{"tip_centre", Vector3d(0.2499, 0, 0)}};
  c.check = [](const std::vector<Vector3d>& u) {
    const double ratio = -u[0].z() / 0.25;
    return Sanity{format("tip deflection %.1f mm = %.1f %% of the length (needs >= 20 %%)", -1e3 * u[0].z(), 100 * ratio),
                  ratio >= 0.2};
  };
  return c;
}

MatrixCase compression() {
  MatrixCase c{"uniaxial_compression", "", 0.1, [] { return box(Vector3d(0, 0, 0), Vector3d(0.1, 0.1, 0.1), 0.02); }, {}, {}};
  c.probes = {{"top_centre", Vector3d(0.05, 0.05, 0.0999)}, {"side_centre", Vector3d(0.0999, 0.05, 0.05)},
              {"side_corner", Vector3d(0.0999, 0.0999, 0.0999)}};
  c.check = [](const std::vector<Vector3d>& u) {
    const double strain = -u[0].z() / 0.0999;  // the probe sits 0.1 mm below the top
    const double b = lateralStretch(1e5, 0.3, 0.7);
    const double side = 1 + u[1].x() / 0.0999, corner = 1 + u[2].x() / 0.0999;
    const bool ok = std::abs(strain - 0.3) < 1e-3 && std::abs(side - b) < 2e-3 && std::abs(corner - b) < 2e-3;
    return Sanity{format("strain %.2f %%, lateral stretch %.4f (side) / ", 100 * strain, side) +
                      format("%.4f (corner), closed form %.4f", corner, b),
                  ok};
  };
  return c;
}

MatrixCase sag() {
  MatrixCase c{"self_weight_sag", "", 0.08, [] { return box(Vector3d(-0.08, -0.08, 0), Vector3d(0.08, 0.08, 0.08), 0.016); }, {}, {}};
  c.probes = {{"top_centre", Vector3d(0, 0, 0.0799)}};
  c.check = [](const std::vector<Vector3d>& u) {
    const double sag = -u[0].z();
    return Sanity{format("top sag %.2f mm = %.1f %% of the height (estimate ~7 mm)", 1e3 * sag, 100 * sag / 0.08),
                  sag > 0.003 && sag < 0.02};
  };
  return c;
}

MatrixCase cook() {
  MatrixCase c{"cook_membrane_plane_strain", "", 0.016,
               [] {
                 render::CookMembraneDimensions d;
                 d.thickness = 0.016;
                 return render::makeCookMembraneMesh(d, 0.002);
               },
               {},
               {}};
  // deal.II's plane-strain reference is read at the middle of the loaded edge, (48, 52) mm (the
  // corner (48, 60) rises about 1 mm less: README "Mechanics").
  c.probes = {{"loaded_edge_mid", Vector3d(0.04799, 0.052, 0.008)}};
  c.check = [](const std::vector<Vector3d>& u) {
    const double uy = u[0].y();
    return Sanity{format("tip u_y %.3f mm vs deal.II Q2 14.74 mm (%+.2f %%)", 1e3 * uy, 100 * (uy / 0.01474 - 1)),
                  std::abs(uy / 0.01474 - 1) < 0.01};
  };
  return c;
}

MatrixCase beam3d() {
  MatrixCase c{"beam3d", "", 1.0, [] { return box(Vector3d(0, 0, 0), Vector3d(4, 1, 1), 0.25); }, {}, {}};
  c.probes = {{"tip", Vector3d(3.9999, 0.5, 0.5)}};
  c.check = [](const std::vector<Vector3d>& u) {
    const double uy = u[0].y();
    return Sanity{format("tip u_y %.4f vs P1 FEM (349k dofs) -1.2054 (%+.2f %%)", uy, 100 * (uy / -1.2054 - 1)),
                  std::abs(uy / -1.2054 - 1) < 0.01};
  };
  return c;
}

}  // namespace

std::vector<MatrixCase> matrixCases() {
  return {tbar(), cuboid(), cantilever(), compression(), sag(), cook(), beam3d()};
}

}  // namespace demnerf::bench
