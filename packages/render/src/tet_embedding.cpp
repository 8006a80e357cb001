#include "demnerf/render/tet_embedding.hpp"

#include <CGAL/Delaunay_triangulation_3.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_vertex_base_with_info_3.h>

#include <Eigen/Dense>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "demnerf/core/error.hpp"

namespace demnerf::render {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using VertexBase = CGAL::Triangulation_vertex_base_with_info_3<int, Kernel>;
using Tds = CGAL::Triangulation_data_structure_3<VertexBase>;
using Delaunay = CGAL::Delaunay_triangulation_3<Kernel, Tds>;

std::string vec(const Eigen::Vector3d& v) {
  std::ostringstream s;
  s << "(" << v.x() << ", " << v.y() << ", " << v.z() << ")";
  return s.str();
}

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

/// Refuses results no embedding can be built from, naming the first problem.
void checkResult(const core::ResultField& result, const TetEmbeddingConfig& config) {
  const std::size_t n = result.positions.size();
  if (n < 4) {
    throw core::Error("deformed render: the result has " + std::to_string(n) +
                      " particles; a body needs at least 4 (is the result file empty?)");
  }
  if (result.displacements.size() != n) {
    throw core::Error("deformed render: the result has " + std::to_string(n) + " positions but " +
                      std::to_string(result.displacements.size()) + " displacements");
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (!result.positions[i].allFinite() || !result.displacements[i].allFinite()) {
      throw core::Error("deformed render: result particle " + std::to_string(i) + " is not finite: position " +
                        vec(result.positions[i]) + ", displacement " + vec(result.displacements[i]));
    }
  }
  if (!(config.max_edge_factor > 0) || !(config.margin_factor >= 0) || !(config.cell_factor > 0)) {
    throw core::Error("deformed render: max_edge_factor and cell_factor must be > 0 and margin_factor >= 0");
  }
}

/// Median nearest-neighbour distance: nearest neighbours are Delaunay edges.
double typicalSpacing(const Delaunay& dt, const std::vector<Eigen::Vector3d>& rest) {
  std::vector<double> nearest(rest.size(), std::numeric_limits<double>::max());
  for (auto e = dt.finite_edges_begin(); e != dt.finite_edges_end(); ++e) {
    const int a = e->first->vertex(e->second)->info(), b = e->first->vertex(e->third)->info();
    const double d = (rest[a] - rest[b]).norm();
    nearest[a] = std::min(nearest[a], d);
    nearest[b] = std::min(nearest[b], d);
  }
  // Duplicates (d = 0) are merged by CGAL and never appear; unreached vertices keep max.
  std::vector<double> finite_nearest;
  for (double d : nearest) if (d < std::numeric_limits<double>::max() && d > 0) finite_nearest.push_back(d);
  if (finite_nearest.empty()) throw core::Error("deformed render: the result's particles have no neighbours");
  return median(finite_nearest);
}

}  // namespace

TetEmbedding::TetEmbedding(const core::ResultField& result, const TetEmbeddingConfig& config) {
  checkResult(result, config);
  const std::size_t n = result.positions.size();
  rest_ = result.positions;
  deformed_.resize(n);
  for (std::size_t i = 0; i < n; ++i) deformed_[i] = rest_[i] + result.displacements[i];

  std::vector<std::pair<Kernel::Point_3, int>> points;
  points.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    points.emplace_back(Kernel::Point_3(rest_[i].x(), rest_[i].y(), rest_[i].z()), static_cast<int>(i));
  }
  Delaunay dt(points.begin(), points.end());
  if (dt.dimension() < 3) {
    throw core::Error("deformed render: the result's " + std::to_string(n) +
                      " rest positions are coplanar (or duplicates); cannot build tetrahedra");
  }
  spacing_ = typicalSpacing(dt, rest_);
  margin_ = config.margin_factor * spacing_;
  min_volume_ratio_ = std::numeric_limits<double>::max();
  for (auto c = dt.finite_cells_begin(); c != dt.finite_cells_end(); ++c) {
    std::array<int, 4> v;
    for (int k = 0; k < 4; ++k) v[k] = c->vertex(k)->info();
    addTetrahedron(v, config, config.max_edge_factor * spacing_);
  }
  if (tets_.empty()) {
    throw core::Error("deformed render: no tetrahedron of the result's " + std::to_string(n) +
                      " particles is shorter than max_edge_factor " + std::to_string(config.max_edge_factor) +
                      " x spacing " + std::to_string(spacing_) + " m (or all are inverted by the displacement)");
  }
  buildLocator(config.cell_factor);
}

void TetEmbedding::addTetrahedron(const std::array<int, 4>& v, const TetEmbeddingConfig& config, double max_edge) {
  double longest = 0;
  for (int a = 0; a < 4; ++a)
    for (int b = a + 1; b < 4; ++b) longest = std::max(longest, (rest_[v[a]] - rest_[v[b]]).norm());
  if (longest > max_edge) return;
  Eigen::Matrix3d rest_edges, def_edges;
  for (int k = 0; k < 3; ++k) {
    rest_edges.col(k) = rest_[v[k + 1]] - rest_[v[0]];
    def_edges.col(k) = deformed_[v[k + 1]] - deformed_[v[0]];
  }
  const double rest_volume = rest_edges.determinant() / 6.0;
  if (std::abs(rest_volume) < config.min_shape * longest * longest * longest) return;
  const double def_volume = def_edges.determinant() / 6.0;
  const double ratio = def_volume / rest_volume;
  min_volume_ratio_ = std::min(min_volume_ratio_, ratio);
  // An inverted deformed tetrahedron cannot be inverted back; it would shadow its neighbours.
  if (!(std::abs(def_volume) > 1e-12 * std::abs(rest_volume)) || ratio <= 0) return;
  const Eigen::Matrix3d inv = def_edges.inverse();
  const Eigen::Matrix3d affine = rest_edges * inv;  // = F^-1
  const Eigen::Matrix3d f = def_edges * rest_edges.inverse();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(f, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d u = svd.matrixU();
  if ((u * svd.matrixV().transpose()).determinant() < 0) u.col(2) = -u.col(2);
  const Eigen::Matrix3d rotation = u * svd.matrixV().transpose();
  Map m;
  for (int a = 0; a < 3; ++a) {
    m.x0[a] = static_cast<float>(deformed_[v[0]][a]);
    m.rest0[a] = static_cast<float>(rest_[v[0]][a]);
    for (int b = 0; b < 3; ++b) {
      m.inv[3 * a + b] = static_cast<float>(inv(a, b));
      m.affine[3 * a + b] = static_cast<float>(affine(a, b));
      m.rotation[3 * a + b] = static_cast<float>(rotation(a, b));
    }
  }
  // b_0 = 1 - b_1 - b_2 - b_3: its gradient is minus the sum of the rows.
  m.plane_scale[0] = static_cast<float>(1.0 / inv.colwise().sum().norm());
  for (int k = 0; k < 3; ++k) m.plane_scale[k + 1] = static_cast<float>(1.0 / inv.row(k).norm());
  tets_.push_back(v);
  maps_.push_back(m);
}

void TetEmbedding::buildLocator(double cell_factor) {
  box_min_ = Eigen::Vector3d::Constant(std::numeric_limits<double>::max());
  box_max_ = -box_min_;
  std::vector<Eigen::Vector3d> lo(tets_.size()), hi(tets_.size());
  for (std::size_t t = 0; t < tets_.size(); ++t) {
    lo[t] = hi[t] = deformed_[tets_[t][0]];
    for (int k = 1; k < 4; ++k) {
      lo[t] = lo[t].cwiseMin(deformed_[tets_[t][k]]);
      hi[t] = hi[t].cwiseMax(deformed_[tets_[t][k]]);
    }
    lo[t].array() -= margin_;
    hi[t].array() += margin_;
    box_min_ = box_min_.cwiseMin(lo[t]);
    box_max_ = box_max_.cwiseMax(hi[t]);
  }
  cell_ = cell_factor * spacing_;
  // Keep the grid to a few million cells whatever the spacing says.
  const Eigen::Vector3d extent = box_max_ - box_min_;
  while ((extent / cell_).array().ceil().prod() > 8e6) cell_ *= 1.5;
  for (int a = 0; a < 3; ++a) dims_[a] = std::max(1, static_cast<int>(std::ceil(extent[a] / cell_)));
  const std::size_t cells = static_cast<std::size_t>(dims_[0]) * dims_[1] * dims_[2];
  auto range = [&](const Eigen::Vector3d& p, const Eigen::Vector3d& q, int* from, int* to) {
    for (int a = 0; a < 3; ++a) {
      from[a] = std::clamp(static_cast<int>((p[a] - box_min_[a]) / cell_), 0, dims_[a] - 1);
      to[a] = std::clamp(static_cast<int>((q[a] - box_min_[a]) / cell_), 0, dims_[a] - 1);
    }
  };
  // Two passes over the tets: count per cell, then fill the CSR lists.
  std::vector<std::int32_t> counts(cells + 1, 0);
  for (int pass = 0; pass < 2; ++pass) {
    if (pass == 1) {
      cell_start_.assign(cells + 1, 0);
      for (std::size_t c = 0; c < cells; ++c) cell_start_[c + 1] = cell_start_[c] + counts[c];
      cell_tets_.resize(cell_start_[cells]);
      std::fill(counts.begin(), counts.end(), 0);
    }
    for (std::size_t t = 0; t < tets_.size(); ++t) {
      int from[3], to[3];
      range(lo[t], hi[t], from, to);
      for (int z = from[2]; z <= to[2]; ++z)
        for (int y = from[1]; y <= to[1]; ++y)
          for (int x = from[0]; x <= to[0]; ++x) {
            const std::size_t c = (static_cast<std::size_t>(z) * dims_[1] + y) * dims_[0] + x;
            if (pass == 1) cell_tets_[cell_start_[c] + counts[c]] = static_cast<std::int32_t>(t);
            ++counts[c];
          }
    }
  }
}

RestPoint TetEmbedding::locate(const float* x) const {
  RestPoint out;
  int c[3];
  for (int a = 0; a < 3; ++a) {
    const double u = (x[a] - box_min_[a]) / cell_;
    if (!(u >= 0 && u < dims_[a])) return out;
    c[a] = static_cast<int>(u);
  }
  const std::size_t cell = (static_cast<std::size_t>(c[2]) * dims_[1] + c[1]) * dims_[0] + c[0];
  // Inside: every signed face distance >= 0. Otherwise the tet whose worst face distance is
  // least negative (nearest by its face planes), if within the margin.
  float best = -static_cast<float>(margin_);
  int best_tet = -1;
  for (std::int32_t i = cell_start_[cell]; i < cell_start_[cell + 1]; ++i) {
    const Map& m = maps_[cell_tets_[i]];
    const float d[3] = {x[0] - m.x0[0], x[1] - m.x0[1], x[2] - m.x0[2]};
    float b[4];
    for (int k = 0; k < 3; ++k) b[k + 1] = m.inv[3 * k] * d[0] + m.inv[3 * k + 1] * d[1] + m.inv[3 * k + 2] * d[2];
    b[0] = 1.0f - b[1] - b[2] - b[3];
    float worst = b[0] * m.plane_scale[0];
    for (int k = 1; k < 4; ++k) worst = std::min(worst, b[k] * m.plane_scale[k]);
    if (worst > best) {
      best = worst;
      best_tet = cell_tets_[i];
      if (worst >= 0.0f) break;
    }
  }
  if (best_tet < 0) return out;
  const Map& m = maps_[best_tet];
  const float d[3] = {x[0] - m.x0[0], x[1] - m.x0[1], x[2] - m.x0[2]};
  for (int a = 0; a < 3; ++a) {
    out.rest[a] = m.rest0[a] + m.affine[3 * a] * d[0] + m.affine[3 * a + 1] * d[1] + m.affine[3 * a + 2] * d[2];
  }
  out.tet = best_tet;
  return out;
}

void TetEmbedding::restDirection(int tet, const float* direction, float* rest_direction) const {
  const float* r = maps_[tet].rotation;
  for (int a = 0; a < 3; ++a) {
    rest_direction[a] = r[a] * direction[0] + r[3 + a] * direction[1] + r[6 + a] * direction[2];
  }
}

}  // namespace demnerf::render
