#include "demnerf/geometry/lattice_crossings.hpp"

#include <algorithm>
#include <cmath>

namespace demnerf::geometry {
namespace {

// Sign of the edge function of edge (a -> b) at point p in the (u, v) plane, for p shifted by
// the infinitesimal (eps, eps^2). The value is always computed from the endpoint with the
// smaller vertex index, so the two faces sharing an edge see bit-identical numbers with
// opposite signs: a line through an edge or vertex is then counted by exactly one face.
int edgeSign(const Eigen::Vector2d& pa, int ia, const Eigen::Vector2d& pb, int ib, const Eigen::Vector2d& p,
             double* value) {
  const bool swapped = ib < ia;
  const Eigen::Vector2d& a = swapped ? pb : pa;
  const Eigen::Vector2d& b = swapped ? pa : pb;
  const double du = b.x() - a.x();
  const double dv = b.y() - a.y();
  double w = du * (p.y() - a.y()) - dv * (p.x() - a.x());
  int sign = (w > 0) - (w < 0);
  if (sign == 0) {
    // d w / d u = -dv, d w / d v = du: the perturbation decides.
    sign = (-dv > 0) - (-dv < 0);
    if (sign == 0) sign = (du > 0) - (du < 0);
  }
  if (swapped) {
    w = -w;
    sign = -sign;
  }
  *value = w;
  return sign;
}

}  // namespace

std::vector<std::vector<LineCrossing>> latticeLineCrossings(const core::TriangleMesh& mesh, const Lattice& lattice,
                                                            int axis) {
  const int u_axis = (axis + 1) % 3;
  const int v_axis = (axis + 2) % 3;
  const int nu = lattice.dims[u_axis];
  const int nv = lattice.dims[v_axis];
  std::vector<std::vector<LineCrossing>> lines(static_cast<std::size_t>(std::max(nu, 0)) * std::max(nv, 0));
  if (lines.empty()) return lines;
  const double ou = lattice.origin[u_axis], su = lattice.spacing[u_axis];
  const double ov = lattice.origin[v_axis], sv = lattice.spacing[v_axis];

  for (std::size_t f = 0; f < mesh.faces.size(); ++f) {
    const auto& face = mesh.faces[f];
    Eigen::Vector2d q[3];
    double t[3];
    for (int c = 0; c < 3; ++c) {
      const Eigen::Vector3d& x = mesh.vertices[face[c]];
      q[c] = Eigen::Vector2d(x[u_axis], x[v_axis]);
      t[c] = x[axis];
    }
    const double umin = std::min({q[0].x(), q[1].x(), q[2].x()});
    const double umax = std::max({q[0].x(), q[1].x(), q[2].x()});
    const double vmin = std::min({q[0].y(), q[1].y(), q[2].y()});
    const double vmax = std::max({q[0].y(), q[1].y(), q[2].y()});
    const int a0 = std::max(0, static_cast<int>(std::ceil((umin - ou) / su)) - 1);
    const int a1 = std::min(nu - 1, static_cast<int>(std::floor((umax - ou) / su)) + 1);
    const int b0 = std::max(0, static_cast<int>(std::ceil((vmin - ov) / sv)) - 1);
    const int b1 = std::min(nv - 1, static_cast<int>(std::floor((vmax - ov) / sv)) + 1);
    for (int b = b0; b <= b1; ++b) {
      for (int a = a0; a <= a1; ++a) {
        const Eigen::Vector2d p(ou + a * su, ov + b * sv);
        double w0, w1, w2;  // edge functions opposite vertex 0, 1, 2
        const int s0 = edgeSign(q[1], face[1], q[2], face[2], p, &w0);
        const int s1 = edgeSign(q[2], face[2], q[0], face[0], p, &w1);
        if (s0 != s1) continue;
        const int s2 = edgeSign(q[0], face[0], q[1], face[1], p, &w2);
        if (s2 != s0) continue;
        const double sum = w0 + w1 + w2;
        // sum == 0 only for a face seen edge-on, whose neighbours carry the crossing.
        if (sum == 0.0) continue;
        const double position = (w0 * t[0] + w1 * t[1] + w2 * t[2]) / sum;
        lines[static_cast<std::size_t>(b) * nu + a].push_back({position, s0, static_cast<int>(f)});
      }
    }
  }
  return lines;
}

std::vector<std::uint8_t> classifyLattice(const core::TriangleMesh& mesh, const Lattice& lattice) {
  std::vector<std::uint8_t> inside(lattice.size(), 0);
  if (inside.empty()) return inside;
  auto lines = latticeLineCrossings(mesh, lattice, 0);
  const int nx = lattice.dims.x();
  for (int k = 0; k < lattice.dims.z(); ++k) {
    for (int j = 0; j < lattice.dims.y(); ++j) {
      auto& crossings = lines[static_cast<std::size_t>(k) * lattice.dims.y() + j];
      if (crossings.empty()) continue;
      std::sort(crossings.begin(), crossings.end(),
                [](const LineCrossing& l, const LineCrossing& r) { return l.position < r.position; });
      // Winding number of the ray towards +x = minus the signed crossings already passed
      // (the total over the whole line is zero for a closed surface).
      int passed = 0;
      std::size_t next = 0;
      for (int i = 0; i < nx; ++i) {
        const double x = lattice.origin.x() + i * lattice.spacing.x();
        while (next < crossings.size() && crossings[next].position <= x) passed += crossings[next++].sign;
        if (-passed > 0) inside[lattice.index(i, j, k)] = 1;
      }
    }
  }
  return inside;
}

}  // namespace demnerf::geometry
