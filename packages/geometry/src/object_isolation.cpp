#include "demnerf/geometry/object_isolation.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "demnerf/core/error.hpp"
#include "demnerf/geometry/density_sampling.hpp"
#include "demnerf/geometry/mesh_analysis.hpp"
#include "demnerf/geometry/optical_depth.hpp"

namespace demnerf::geometry {
namespace {

// Labels the 6-connected pieces of {field >= level}; returns each node's piece (-1 outside)
// and fills `sizes` (indexed by label). A breadth-first flood with an explicit queue, so a large
// piece cannot overflow the stack.
std::vector<int> labelPieces(const DensityGrid& field, double level, std::vector<std::size_t>* sizes) {
  const Eigen::Vector3i& n = field.dims;
  std::vector<int> label(field.values.size(), -1);
  std::vector<std::size_t> queue;
  const int offsets[6][3] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (std::size_t seed = 0; seed < label.size(); ++seed) {
    if (label[seed] >= 0 || !(field.values[seed] >= level)) continue;
    const int piece = static_cast<int>(sizes->size());
    sizes->push_back(0);
    queue.assign(1, seed);
    label[seed] = piece;
    while (!queue.empty()) {
      const std::size_t id = queue.back();
      queue.pop_back();
      ++(*sizes)[piece];
      const int i = static_cast<int>(id % n.x()), j = static_cast<int>((id / n.x()) % n.y());
      const int k = static_cast<int>(id / (static_cast<std::size_t>(n.x()) * n.y()));
      for (const auto& d : offsets) {
        const int a = i + d[0], b = j + d[1], c = k + d[2];
        if (a < 0 || b < 0 || c < 0 || a >= n.x() || b >= n.y() || c >= n.z()) continue;
        const std::size_t next = field.index(a, b, c);
        if (label[next] >= 0 || !(field.values[next] >= level)) continue;
        label[next] = piece;
        queue.push_back(next);
      }
    }
  }
  return label;
}

std::string emptyBoxMessage(const DensityGrid& boxed, double peak, double level, bool opacity) {
  const Eigen::Vector3d low = boxed.origin;
  const Eigen::Vector3d high = boxed.node(boxed.dims.x() - 1, boxed.dims.y() - 1, boxed.dims.z() - 1);
  std::ostringstream message;
  message << "the box (grid nodes " << formatBox(Eigen::AlignedBox3d(low, high))
          << ") is empty: no point inside reaches the surface ("
          << (opacity ? "optical depth " : "density ") << level << "; the largest inside is " << peak
          << "). The box is given in the model's frame (the poses' units, as `demnerf info` prints the scene box): "
          << "check its axes and units, or that the model is trained";
  return message.str();
}

}  // namespace

std::optional<std::vector<double>> parseNumberList(const std::string& text) {
  std::vector<double> numbers;
  std::stringstream stream(text);
  std::string item;
  while (std::getline(stream, item, ',')) {
    try {
      std::size_t used = 0;
      numbers.push_back(std::stod(item, &used));
      if (item.find_first_not_of(" \t", used) != std::string::npos || !std::isfinite(numbers.back())) return std::nullopt;
    } catch (const std::exception&) {
      return std::nullopt;
    }
  }
  return numbers;
}

Eigen::AlignedBox3d parseBox(const std::string& text) {
  const std::optional<std::vector<double>> parsed = parseNumberList(text);
  if (!parsed || parsed->size() != 6) {
    throw core::Error("box '" + text + "' must be six numbers xmin,ymin,zmin,xmax,ymax,zmax (the model's frame)");
  }
  const std::vector<double>& numbers = *parsed;
  const Eigen::Vector3d low(numbers[0], numbers[1], numbers[2]), high(numbers[3], numbers[4], numbers[5]);
  if (!(low.array() < high.array()).all()) {
    throw core::Error("box '" + text + "' must have xmin < xmax, ymin < ymax and zmin < zmax");
  }
  return Eigen::AlignedBox3d(low, high);
}

std::string formatBox(const Eigen::AlignedBox3d& box) {
  std::ostringstream text;
  text << box.min().x() << ',' << box.min().y() << ',' << box.min().z() << ',' << box.max().x() << ','
       << box.max().y() << ',' << box.max().z();
  return text.str();
}

DensityGrid closeAtBorder(const DensityGrid& grid) {
  grid.validate();
  DensityGrid closed = grid;
  const Eigen::Vector3i last = grid.dims - Eigen::Vector3i::Ones();
  for (int k = 0; k < grid.dims.z(); ++k) {
    for (int j = 0; j < grid.dims.y(); ++j) {
      for (int i = 0; i < grid.dims.x(); ++i) {
        if (i == 0 || j == 0 || k == 0 || i == last.x() || j == last.y() || k == last.z()) {
          closed.values[grid.index(i, j, k)] = 0.0f;
        }
      }
    }
  }
  return closed;
}

DensityGrid sampleDensityInBox(const DensityFunction& density, const Eigen::AlignedBox3d& box, int resolution) {
  return closeAtBorder(sampleDensityGrid(density, box, resolution));
}

void requireClosedIsolation(const core::TriangleMesh& mesh) {
  const MeshSummary summary = analyzeMesh(mesh);
  if (summary.closed()) return;
  std::ostringstream message;
  message << "the isolated surface is open (" << summary.boundary_edges << " boundary, " << summary.non_manifold_edges
          << " non-manifold, " << summary.misoriented_edges << " misoriented edges): a closed body is needed to fill"
          << " with particles; give a box (--box) so the surface is capped at its faces, or raise the resolution";
  throw core::Error(message.str());
}

MeshExtractionResult isolateObject(const DensityGrid& boxed, const MeshExtractionConfig& extraction,
                                   const IsolationConfig& isolation, IsolationReport* report) {
  IsolationReport local;
  IsolationReport& out = report ? *report : local;
  out = IsolationReport{};
  DensityGrid grid = closeAtBorder(boxed);
  // Pieces are found on the field the surface is cut from, at the surface's own level.
  const bool opacity = extraction.surface == SurfaceDefinition::kOpacity;
  const double level = opacity ? -std::log(1.0 - extraction.opacity) : extraction.threshold;
  const DensityGrid field = opacity ? axisOpticalDepth(grid) : grid;
  out.peak = *std::max_element(field.values.begin(), field.values.end());
  if (!(out.peak >= level)) throw core::Error(emptyBoxMessage(grid, out.peak, level, opacity));
  std::vector<std::size_t> sizes;
  const std::vector<int> label = labelPieces(field, level, &sizes);
  const int largest = static_cast<int>(std::max_element(sizes.begin(), sizes.end()) - sizes.begin());
  out.pieces = sizes.size();
  out.piece_nodes = sizes;
  std::sort(out.piece_nodes.rbegin(), out.piece_nodes.rend());
  if (out.pieces > 1 && out.piece_nodes[1] >= isolation.max_second_piece_fraction * out.piece_nodes[0]) {
    std::ostringstream message;
    message << "the box holds " << out.pieces << " separate pieces (grid nodes:";
    for (std::size_t p = 0; p < std::min<std::size_t>(out.pieces, 5); ++p) message << ' ' << out.piece_nodes[p];
    message << (out.pieces > 5 ? " ..." : "") << "); the second is " << out.piece_nodes[1] << " nodes, at least "
            << isolation.max_second_piece_fraction << " of the largest, so the box takes in more than one object:"
            << " shrink the box around the one to simulate, or allow a larger second piece to keep the largest anyway"
            << " (demnerf extract --max-second-piece)";
    throw core::Error(message.str());
  }
  for (std::size_t id = 0; id < label.size(); ++id) {
    if (label[id] >= 0 && label[id] != largest) {
      grid.values[id] = 0.0f;
      ++out.nodes_dropped;
    }
  }
  MeshExtractionResult result = extractMesh(grid, extraction);
  requireClosedIsolation(result.mesh);
  return result;
}

}  // namespace demnerf::geometry
