// Particle clouds and results as binary PLY (fields in DESIGN.md), through the column table.

#include "demnerf/core/ply.hpp"

#include "demnerf/core/error.hpp"
#include "detail/ply_table.hpp"

namespace demnerf::core {
namespace {

using detail::PlyTable;

struct Columns {
  std::vector<std::string> names;
  std::vector<std::vector<double>> values;
  std::vector<double>& add(const std::string& name, std::size_t rows) {
    names.push_back(name);
    values.emplace_back(rows);
    return values.back();
  }
  void write(const std::string& path, const std::vector<std::string>& bytes) const {
    std::vector<const std::vector<double>*> pointers;
    for (const auto& column : values) pointers.push_back(&column);
    detail::writePlyTable(path, names, pointers, bytes);
  }
};

void addVectors(Columns& columns, const std::vector<Eigen::Vector3d>& vectors, const char* x,
                const char* y, const char* z) {
  const char* names[3] = {x, y, z};
  for (int axis = 0; axis < 3; ++axis) {
    auto& column = columns.add(names[axis], vectors.size());
    for (std::size_t i = 0; i < vectors.size(); ++i) column[i] = vectors[i][axis];
  }
}

std::vector<Eigen::Vector3d> readVectors(const PlyTable& table, const std::string& path,
                                         const char* x, const char* y, const char* z) {
  const auto& cx = table.column(x, path);
  const auto& cy = table.column(y, path);
  const auto& cz = table.column(z, path);
  std::vector<Eigen::Vector3d> vectors(table.vertex_count);
  for (std::size_t i = 0; i < vectors.size(); ++i) vectors[i] = {cx[i], cy[i], cz[i]};
  return vectors;
}

}  // namespace

void writeParticles(const std::string& path, const ParticleCloud& cloud) {
  cloud.validate();
  Columns columns;
  addVectors(columns, cloud.positions, "x", "y", "z");
  columns.add("volume", cloud.size()) = cloud.volumes;
  addVectors(columns, cloud.normals, "nx", "ny", "nz");
  columns.add("area", cloud.size()) = cloud.areas;
  const char* channel_names[3] = {"red", "green", "blue"};
  for (int channel = 0; channel < 3; ++channel) {
    auto& column = columns.add(channel_names[channel], cloud.size());
    for (std::size_t i = 0; i < cloud.size(); ++i) column[i] = cloud.colors[i][channel];
  }
  columns.write(path, {"red", "green", "blue"});
}

ParticleCloud readParticles(const std::string& path) {
  const PlyTable table = detail::readPlyTable(path);
  if (table.vertex_count == 0) throw Error("particle file '" + path + "' holds no particles");
  ParticleCloud cloud;
  cloud.positions = readVectors(table, path, "x", "y", "z");
  cloud.volumes = table.column("volume", path);
  cloud.normals = readVectors(table, path, "nx", "ny", "nz");
  cloud.areas = table.column("area", path);
  cloud.colors.assign(table.vertex_count, {200, 200, 200});
  if (table.vertex_columns.count("red")) {
    const auto& r = table.column("red", path);
    const auto& g = table.column("green", path);
    const auto& b = table.column("blue", path);
    for (std::size_t i = 0; i < table.vertex_count; ++i) {
      cloud.colors[i] = {static_cast<std::uint8_t>(r[i]), static_cast<std::uint8_t>(g[i]), static_cast<std::uint8_t>(b[i])};
    }
  }
  try {
    cloud.validate();
  } catch (const Error& error) {
    throw Error("'" + path + "': " + error.what());
  }
  return cloud;
}

void writeResult(const std::string& path, const ResultField& result) {
  result.validate();
  Columns columns;
  addVectors(columns, result.positions, "x", "y", "z");
  addVectors(columns, result.displacements, "ux", "uy", "uz");
  columns.add("von_mises", result.size()) = result.von_mises;
  columns.write(path, {});
}

ResultField readResult(const std::string& path) {
  const PlyTable table = detail::readPlyTable(path);
  if (table.vertex_count == 0) throw Error("result file '" + path + "' holds no rows");
  ResultField result;
  result.positions = readVectors(table, path, "x", "y", "z");
  result.displacements = readVectors(table, path, "ux", "uy", "uz");
  result.von_mises = table.vertex_columns.count("von_mises") ? table.column("von_mises", path)
                                                             : std::vector<double>(table.vertex_count, 0.0);
  try {
    result.validate();
  } catch (const Error& error) {
    throw Error("'" + path + "': " + error.what());
  }
  return result;
}

}  // namespace demnerf::core
