#include "demnerf/geometry/solid_body.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <sstream>
#include <unordered_set>

#include "demnerf/core/error.hpp"

namespace demnerf::geometry {
namespace {

// Stands for "no feature on this line yet"; large enough that no real squared distance comes
// near, small enough that sums and differences with it stay finite (no inf - inf = NaN).
constexpr double kFar = 1e30;

// One axis of the exact distance transform: out[p] = min_q in[q] + (w (p - q))^2 along a line of
// n nodes spaced w apart (the lower envelope of the parabolas rooted at each q). `v` and `z` are
// scratch: the envelope's parabolas and the abscissae where each takes over.
void envelope1d(const double* in, double* out, int n, double w, std::vector<int>& v, std::vector<double>& z) {
  const double w2 = w * w;
  auto cross = [&](int q, int p) {  // where the parabolas rooted at q and p > q meet
    return ((in[p] + w2 * p * p) - (in[q] + w2 * q * q)) / (2.0 * w2 * (p - q));
  };
  int k = 0;
  v[0] = 0;
  z[0] = -std::numeric_limits<double>::infinity();
  z[1] = std::numeric_limits<double>::infinity();
  for (int q = 1; q < n; ++q) {
    double s = cross(v[k], q);
    while (s <= z[k]) s = cross(v[--k], q);
    ++k;
    v[k] = q;
    z[k] = s;
    z[k + 1] = std::numeric_limits<double>::infinity();
  }
  k = 0;
  for (int p = 0; p < n; ++p) {
    while (z[k + 1] < p) ++k;
    const double d = w * (p - v[k]);
    out[p] = std::min(kFar, in[v[k]] + d * d);
  }
}

// Outside nodes (not in `solid`) that no 6-connected path of outside nodes joins to the border.
std::vector<char> enclosedOutside(const DensityGrid& grid, const std::vector<char>& solid) {
  const Eigen::Vector3i& n = grid.dims;
  std::vector<char> reached(solid.size(), 0);
  std::vector<std::size_t> queue;
  auto visit = [&](int i, int j, int k) {
    const std::size_t id = grid.index(i, j, k);
    if (solid[id] || reached[id]) return;
    reached[id] = 1;
    queue.push_back(id);
  };
  for (int k = 0; k < n.z(); ++k)
    for (int j = 0; j < n.y(); ++j)
      for (int i = 0; i < n.x(); ++i)
        if (i == 0 || j == 0 || k == 0 || i == n.x() - 1 || j == n.y() - 1 || k == n.z() - 1) visit(i, j, k);
  while (!queue.empty()) {
    const std::size_t id = queue.back();
    queue.pop_back();
    const int i = static_cast<int>(id % n.x()), j = static_cast<int>((id / n.x()) % n.y());
    const int k = static_cast<int>(id / (static_cast<std::size_t>(n.x()) * n.y()));
    if (i > 0) visit(i - 1, j, k);
    if (i + 1 < n.x()) visit(i + 1, j, k);
    if (j > 0) visit(i, j - 1, k);
    if (j + 1 < n.y()) visit(i, j + 1, k);
    if (k > 0) visit(i, j, k - 1);
    if (k + 1 < n.z()) visit(i, j, k + 1);
  }
  std::vector<char> enclosed(solid.size(), 0);
  for (std::size_t id = 0; id < solid.size(); ++id) enclosed[id] = !solid[id] && !reached[id];
  return enclosed;
}

// The closing of `inside` by a ball of radius r: nodes within r of the inside (dilation), less
// those within r of what the dilation left outside (erosion). Both distances are exact, so the
// closing contains `inside` itself.
std::vector<char> closing(const DensityGrid& grid, const std::vector<char>& inside, double radius) {
  const double limit = radius * radius * (1.0 + 1e-9);  // a node exactly r away counts as within
  const std::vector<double> to_inside = squaredDistanceTo(grid, inside);
  std::vector<char> dilated_out(inside.size());
  for (std::size_t id = 0; id < inside.size(); ++id) dilated_out[id] = !(to_inside[id] <= limit);
  const std::vector<double> to_outside = squaredDistanceTo(grid, dilated_out);
  std::vector<char> closed(inside.size());
  for (std::size_t id = 0; id < inside.size(); ++id) closed[id] = inside[id] || to_outside[id] > limit;
  return closed;
}

// Nodes whose ray along `toward` (unit) meets `solid` before it leaves the grid. Each ray is
// marched in half-cell steps, only over the stretch that crosses the solid's bounding box.
std::vector<char> hiddenBehind(const DensityGrid& grid, const std::vector<char>& solid, const Eigen::Vector3d& toward) {
  const Eigen::Vector3i& n = grid.dims;
  Eigen::Vector3i low = n, high = Eigen::Vector3i::Constant(-1);
  for (int k = 0; k < n.z(); ++k)
    for (int j = 0; j < n.y(); ++j)
      for (int i = 0; i < n.x(); ++i)
        if (solid[grid.index(i, j, k)]) {
          low = low.cwiseMin(Eigen::Vector3i(i, j, k));
          high = high.cwiseMax(Eigen::Vector3i(i, j, k));
        }
  std::vector<char> hidden(solid.size(), 0);
  if ((high.array() < 0).any()) return hidden;
  const Eigen::Vector3d step = toward.cwiseQuotient(grid.spacing) * 0.5 * grid.spacing.minCoeff();  // in cells
  const Eigen::Vector3d box_low = low.cast<double>() - Eigen::Vector3d::Constant(0.5);
  const Eigen::Vector3d box_high = high.cast<double>() + Eigen::Vector3d::Constant(0.5);
  for (int k = 0; k < n.z(); ++k) {
    for (int j = 0; j < n.y(); ++j) {
      for (int i = 0; i < n.x(); ++i) {
        const std::size_t id = grid.index(i, j, k);
        if (solid[id]) continue;
        const Eigen::Vector3d start(i, j, k);
        double t0 = 1.0, t1 = std::numeric_limits<double>::infinity();  // in steps, along the ray
        for (int a = 0; a < 3; ++a) {
          if (step[a] == 0.0) {
            if (start[a] < box_low[a] || start[a] > box_high[a]) t1 = -1.0;
            continue;
          }
          const double ta = (box_low[a] - start[a]) / step[a], tb = (box_high[a] - start[a]) / step[a];
          t0 = std::max(t0, std::ceil(std::min(ta, tb)));
          t1 = std::min(t1, std::max(ta, tb));
        }
        for (double t = t0; t <= t1 && !hidden[id]; t += 1.0) {
          const Eigen::Vector3i q = (start + t * step).array().round().cast<int>();
          if ((q.array() < 0).any() || (q.array() >= n.array()).any()) break;
          hidden[id] = solid[grid.index(q.x(), q.y(), q.z())];
        }
      }
    }
  }
  return hidden;
}

}  // namespace

std::vector<double> squaredDistanceTo(const DensityGrid& grid, const std::vector<char>& feature) {
  const Eigen::Vector3i& n = grid.dims;
  std::vector<double> d2(feature.size());
  for (std::size_t id = 0; id < feature.size(); ++id) d2[id] = feature[id] ? 0.0 : kFar;
  const std::size_t strides[3] = {1, static_cast<std::size_t>(n.x()), static_cast<std::size_t>(n.x()) * n.y()};
  const int longest = n.maxCoeff();
  std::vector<double> line(longest), result(longest), z(longest + 1);
  std::vector<int> v(longest);
  for (int axis = 0; axis < 3; ++axis) {
    const int b = (axis + 1) % 3, c = (axis + 2) % 3;
    for (int t = 0; t < n[c]; ++t) {
      for (int u = 0; u < n[b]; ++u) {
        const std::size_t start = u * strides[b] + t * strides[c];
        for (int s = 0; s < n[axis]; ++s) line[s] = d2[start + s * strides[axis]];
        envelope1d(line.data(), result.data(), n[axis], grid.spacing[axis], v, z);
        for (int s = 0; s < n[axis]; ++s) d2[start + s * strides[axis]] = result[s];
      }
    }
  }
  return d2;
}

DensityGrid solidifyField(const DensityGrid& field, double level, const SolidConfig& config, SolidReport* report) {
  field.validate();
  if (!(config.radius >= 0.0) || !std::isfinite(config.radius) || !config.behind.allFinite()) {
    std::ostringstream message;
    message << "solid radius " << config.radius << " must be a finite length >= 0 in the scene's units (0: no "
            << "closing), and the direction behind (" << config.behind.transpose() << ") finite";
    throw core::Error(message.str());
  }
  if (config.min_views < 1) throw core::Error("solid: min_views must be >= 1, got " + std::to_string(config.min_views));
  if (!config.cameras.empty() && config.behind != Eigen::Vector3d::Zero()) {
    throw core::Error("solid: give either the capture's cameras (space carving) or one direction behind the body, "
                      "not both; the cameras' fill is the tighter one");
  }
  SolidReport local;
  SolidReport& out = report ? *report : local;
  out = SolidReport{};
  out.radius_cells = config.radius / field.spacing.maxCoeff();
  std::vector<char> inside(field.values.size());
  for (std::size_t id = 0; id < inside.size(); ++id) inside[id] = field.values[id] > level;
  const std::vector<char> closed = config.radius > 0.0 ? closing(field, inside, config.radius) : inside;
  std::vector<char> hidden(inside.size(), 0);
  if (config.behind != Eigen::Vector3d::Zero()) hidden = hiddenBehind(field, closed, config.behind.normalized());
  if (!config.cameras.empty()) {
    CarvingReport carving;
    hidden = unseenByCameras(field, closed, config.cameras, config.min_views, &carving);
    out.unseen_nodes = carving.unseen;
  }
  std::vector<char> solid_mask = closed;
  for (std::size_t id = 0; id < inside.size(); ++id) solid_mask[id] = closed[id] || hidden[id];
  // The carved fill meets the closed body along seams a grazing view slips through (slits a cell
  // or two wide, genus 78 on the fox without this, 4 with it): the closing is taken once more on
  // the union, which shuts them and leaves the carved outline alone elsewhere.
  if (!config.cameras.empty() && config.radius > 0.0) {
    solid_mask = closing(field, solid_mask, config.radius);
    for (std::size_t id = 0; id < inside.size(); ++id) hidden[id] = solid_mask[id] && !closed[id];
  }
  const std::vector<char> enclosed = enclosedOutside(field, solid_mask);
  const float fill = static_cast<float>(level > 0.0 ? 2.0 * level : level + 1.0);
  DensityGrid solid = field;
  const Eigen::Vector3i& n = field.dims;
  // The outermost layer stays as it is: a box's cut is capped there (closeAtBorder), and a
  // closing that filled it would move the cap out by a cell.
  for (int k = 1; k + 1 < n.z(); ++k) {
    for (int j = 1; j + 1 < n.y(); ++j) {
      for (int i = 1; i + 1 < n.x(); ++i) {
        const std::size_t id = field.index(i, j, k);
        if (inside[id] || !(solid_mask[id] || enclosed[id])) continue;
        solid.values[id] = std::max(solid.values[id], fill);
        ++(closed[id] ? out.closed_nodes : hidden[id] ? out.hidden_nodes : out.cavity_nodes);
      }
    }
  }
  return solid;
}

SurfaceTopology surfaceTopology(const core::TriangleMesh& mesh) {
  std::vector<std::size_t> parent(mesh.vertices.size());
  std::iota(parent.begin(), parent.end(), std::size_t{0});
  auto root = [&](std::size_t a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  };
  std::vector<char> used(mesh.vertices.size(), 0);
  std::unordered_set<std::uint64_t> edges;
  edges.reserve(mesh.faces.size() * 2);
  for (const auto& face : mesh.faces) {
    for (int c = 0; c < 3; ++c) {
      const std::size_t a = face[c], b = face[(c + 1) % 3];
      used[a] = 1;
      edges.insert(static_cast<std::uint64_t>(std::min(a, b)) << 32 | std::max(a, b));
      parent[root(a)] = root(b);
    }
  }
  SurfaceTopology topology;
  long long vertices = 0;
  for (std::size_t a = 0; a < used.size(); ++a) {
    if (!used[a]) continue;
    ++vertices;
    topology.components += root(a) == a;
  }
  topology.euler = vertices - static_cast<long long>(edges.size()) + static_cast<long long>(mesh.faces.size());
  topology.genus = static_cast<long long>(topology.components) - topology.euler / 2;
  return topology;
}

}  // namespace demnerf::geometry
