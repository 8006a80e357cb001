#include "demnerf/mechanics/bspline_grid.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "demnerf/core/error.hpp"

namespace demnerf::mechanics {
namespace {

// The degree + 1 uniform B-spline pieces that cover a cell, at local coordinate t in [0, 1), and
// their derivatives in t; piece j belongs to the basis function j cells to the right of the first.
void pieces(int degree, double t, double* b, double* db) {
  const double s = 1.0 - t;
  switch (degree) {
    case 1:
      b[0] = s, b[1] = t;
      db[0] = -1.0, db[1] = 1.0;
      return;
    case 2:
      b[0] = 0.5 * s * s, b[1] = 0.5 + t * s, b[2] = 0.5 * t * t;
      db[0] = -s, db[1] = 1.0 - 2.0 * t, db[2] = t;
      return;
    default: {
      const double t2 = t * t, t3 = t2 * t;
      b[0] = s * s * s / 6.0;
      b[1] = (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0;
      b[2] = (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0;
      b[3] = t3 / 6.0;
      db[0] = -0.5 * s * s;
      db[1] = 1.5 * t2 - 2.0 * t;
      db[2] = -1.5 * t2 + t + 0.5;
      db[3] = 0.5 * t2;
    }
  }
}

}  // namespace

BsplineGrid::BsplineGrid(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double cell, int degree)
    : degree_(degree), cell_(cell) {
  if (degree < 1 || degree > 3) throw core::Error("B-spline grid degree " + std::to_string(degree) + ": use 1, 2 or 3");
  if (!(cell > 0) || !std::isfinite(cell)) throw core::Error("B-spline grid cell size must be positive and finite");
  const Eigen::Vector3d size = (hi - lo).cwiseMax(0.0);
  for (int a = 0; a < 3; ++a) cells_(a) = std::max(1, static_cast<int>(std::ceil(size(a) / cell - 1e-9)));
  origin_ = 0.5 * (lo + hi) - 0.5 * cell * cells_.cast<double>();
}

long BsplineGrid::nodeCount() const {
  return static_cast<long>(cells_(0) + degree_) * (cells_(1) + degree_) * (cells_(2) + degree_);
}

long BsplineGrid::cellIndex(const Eigen::Vector3d& x) const {
  long index = 0;
  for (int a = 2; a >= 0; --a) {
    const int i = std::clamp(static_cast<int>(std::floor((x(a) - origin_(a)) / cell_)), 0, cells_(a) - 1);
    index = index * cells_(a) + i;
  }
  return index;
}

void BsplineGrid::evaluate(const Eigen::Vector3d& x, long* nodes, double* values, Eigen::Vector3d* gradients) const {
  const int n = degree_ + 1;
  int first[3];
  double b[3][4], db[3][4];
  for (int a = 0; a < 3; ++a) {
    const double u = (x(a) - origin_(a)) / cell_;
    first[a] = std::clamp(static_cast<int>(std::floor(u)), 0, cells_(a) - 1);
    pieces(degree_, u - first[a], b[a], db[a]);
    for (int j = 0; j < n; ++j) db[a][j] /= cell_;
  }
  const long nx = cells_(0) + degree_, ny = cells_(1) + degree_;
  int s = 0;
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i, ++s) {
        nodes[s] = (first[2] + k) * nx * ny + (first[1] + j) * nx + (first[0] + i);
        values[s] = b[0][i] * b[1][j] * b[2][k];
        gradients[s] = Eigen::Vector3d(db[0][i] * b[1][j] * b[2][k], b[0][i] * db[1][j] * b[2][k],
                                       b[0][i] * b[1][j] * db[2][k]);
      }
}

}  // namespace demnerf::mechanics
