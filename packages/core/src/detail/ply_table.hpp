#pragma once
// A PLY file read into columns: every scalar property of the vertex element as doubles, and
// the face element's vertex index lists. Shared by the particle, result and mesh readers.

#include <array>
#include <map>
#include <string>
#include <vector>

namespace demnerf::core::detail {

struct PlyTable {
  std::size_t vertex_count = 0;
  std::map<std::string, std::vector<double>> vertex_columns;
  std::vector<std::vector<int>> faces;

  /// The column named `name`; core::Error naming the file and the missing field otherwise.
  const std::vector<double>& column(const std::string& name, const std::string& path) const;
};

/// Reads ascii or binary_little_endian PLY; core::Error with the file name on any defect.
PlyTable readPlyTable(const std::string& path);

/// Writes a binary little-endian PLY with float32 vertex columns (and uint8 for names listed in
/// `byte_columns`) and, when `faces` is non-empty, a face element of int32 index triples.
void writePlyTable(const std::string& path, const std::vector<std::string>& names,
                   const std::vector<const std::vector<double>*>& columns,
                   const std::vector<std::string>& byte_columns,
                   const std::vector<std::array<int, 3>>& faces = {});

}  // namespace demnerf::core::detail
