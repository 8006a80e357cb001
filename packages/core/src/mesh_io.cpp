// Triangle meshes from PLY or OBJ, and to binary PLY.

#include <fstream>
#include <sstream>

#include "demnerf/core/error.hpp"
#include "demnerf/core/ply.hpp"
#include "detail/ply_table.hpp"

namespace demnerf::core {
namespace {

bool endsWith(const std::string& text, const std::string& suffix) {
  if (text.size() < suffix.size()) return false;
  std::string tail = text.substr(text.size() - suffix.size());
  for (char& c : tail) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return tail == suffix;
}

// Splits a polygon into a triangle fan; checks every index against the vertex count.
void addPolygon(TriangleMesh& mesh, const std::vector<int>& polygon, const std::string& path) {
  if (polygon.size() < 3) throw Error("mesh '" + path + "': a face has fewer than 3 vertices");
  for (int index : polygon) {
    if (index < 0 || index >= static_cast<int>(mesh.vertices.size())) {
      throw Error("mesh '" + path + "': face index " + std::to_string(index) + " is out of range (" +
                  std::to_string(mesh.vertices.size()) + " vertices)");
    }
  }
  for (std::size_t k = 1; k + 1 < polygon.size(); ++k) {
    mesh.faces.push_back({polygon[0], polygon[k], polygon[k + 1]});
  }
}

TriangleMesh readObj(const std::string& path) {
  std::ifstream stream(path);
  if (!stream) throw Error("cannot open mesh '" + path + "'");
  TriangleMesh mesh;
  std::vector<std::vector<int>> polygons;
  std::string line;
  int line_number = 0;
  while (std::getline(stream, line)) {
    ++line_number;
    std::istringstream words(line);
    std::string keyword;
    words >> keyword;
    if (keyword == "v") {
      Eigen::Vector3d v;
      if (!(words >> v.x() >> v.y() >> v.z()) || !v.allFinite()) {
        throw Error("mesh '" + path + "' line " + std::to_string(line_number) + ": bad vertex '" + line + "'");
      }
      mesh.vertices.push_back(v);
    } else if (keyword == "f") {
      std::vector<int> polygon;
      std::string token;
      while (words >> token) {
        // "7", "7/2" and "7/2/5" all name vertex 7 (1-based; negative counts from the end).
        const int index = std::stoi(token.substr(0, token.find('/')));
        polygon.push_back(index > 0 ? index - 1 : static_cast<int>(mesh.vertices.size()) + index);
      }
      polygons.push_back(polygon);
    }
  }
  for (const auto& polygon : polygons) addPolygon(mesh, polygon, path);
  return mesh;
}

}  // namespace

TriangleMesh readMesh(const std::string& path) {
  TriangleMesh mesh;
  if (endsWith(path, ".obj")) {
    mesh = readObj(path);
  } else if (endsWith(path, ".ply")) {
    const detail::PlyTable table = detail::readPlyTable(path);
    const auto& x = table.column("x", path);
    const auto& y = table.column("y", path);
    const auto& z = table.column("z", path);
    for (std::size_t i = 0; i < table.vertex_count; ++i) mesh.vertices.emplace_back(x[i], y[i], z[i]);
    for (const auto& polygon : table.faces) addPolygon(mesh, polygon, path);
  } else {
    throw Error("mesh '" + path + "': unknown file type (use .ply or .obj)");
  }
  if (mesh.vertices.empty() || mesh.faces.empty()) {
    throw Error("mesh '" + path + "' has no triangles");
  }
  return mesh;
}

void writeMesh(const std::string& path, const TriangleMesh& mesh) {
  std::vector<std::vector<double>> xyz(3, std::vector<double>(mesh.vertices.size()));
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    for (int axis = 0; axis < 3; ++axis) xyz[axis][i] = mesh.vertices[i][axis];
  }
  detail::writePlyTable(path, {"x", "y", "z"}, {&xyz[0], &xyz[1], &xyz[2]}, {}, mesh.faces);
}

}  // namespace demnerf::core
