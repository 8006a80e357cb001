#include "detail/ply_table.hpp"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "demnerf/core/error.hpp"

namespace demnerf::core::detail {
namespace {

struct Property {
  std::string name;
  std::string type;        // scalar type, or the item type of a list
  std::string count_type;  // non-empty for lists
};

struct Element {
  std::string name;
  std::size_t count = 0;
  std::vector<Property> properties;
};

std::size_t typeSize(const std::string& type, const std::string& path) {
  if (type == "char" || type == "uchar" || type == "int8" || type == "uint8") return 1;
  if (type == "short" || type == "ushort" || type == "int16" || type == "uint16") return 2;
  if (type == "int" || type == "uint" || type == "float" || type == "int32" || type == "uint32" || type == "float32") return 4;
  if (type == "double" || type == "float64") return 8;
  throw Error("PLY '" + path + "': unknown property type '" + type + "'");
}

double decode(const char* bytes, const std::string& type) {
  auto read = [bytes](auto value) { std::memcpy(&value, bytes, sizeof(value)); return static_cast<double>(value); };
  if (type == "char" || type == "int8") return read(std::int8_t{});
  if (type == "uchar" || type == "uint8") return read(std::uint8_t{});
  if (type == "short" || type == "int16") return read(std::int16_t{});
  if (type == "ushort" || type == "uint16") return read(std::uint16_t{});
  if (type == "int" || type == "int32") return read(std::int32_t{});
  if (type == "uint" || type == "uint32") return read(std::uint32_t{});
  if (type == "float" || type == "float32") return read(float{});
  return read(double{});
}

class ValueSource {
 public:
  ValueSource(std::istream& stream, bool binary, const std::string& path)
      : stream_(stream), binary_(binary), path_(path) {}
  double next(const std::string& type) {
    if (binary_) {
      char bytes[8];
      const std::size_t size = typeSize(type, path_);
      if (!stream_.read(bytes, static_cast<std::streamsize>(size))) {
        throw Error("PLY '" + path_ + "' is truncated (fewer values than its header promises)");
      }
      return decode(bytes, type);
    }
    double value;
    if (!(stream_ >> value)) throw Error("PLY '" + path_ + "' is truncated or holds a non-number");
    return value;
  }

 private:
  std::istream& stream_;
  bool binary_;
  std::string path_;
};

}  // namespace

const std::vector<double>& PlyTable::column(const std::string& name, const std::string& path) const {
  const auto it = vertex_columns.find(name);
  if (it == vertex_columns.end()) {
    throw Error("PLY '" + path + "' has no vertex property '" + name + "'");
  }
  return it->second;
}

PlyTable readPlyTable(const std::string& path) {
  std::ifstream stream(path, std::ios::binary);
  if (!stream) throw Error("cannot open PLY file '" + path + "'");
  std::string line;
  if (!std::getline(stream, line) || line.rfind("ply", 0) != 0) {
    throw Error("'" + path + "' is not a PLY file (first line must be 'ply')");
  }
  bool binary = false;
  std::vector<Element> elements;
  while (std::getline(stream, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream words(line);
    std::string keyword;
    words >> keyword;
    if (keyword == "format") {
      std::string format;
      words >> format;
      if (format == "binary_little_endian") binary = true;
      else if (format != "ascii") throw Error("PLY '" + path + "': format '" + format + "' is not supported (use ascii or binary_little_endian)");
    } else if (keyword == "element") {
      Element element;
      long long count = -1;
      words >> element.name >> count;
      if (count < 0) throw Error("PLY '" + path + "': bad element line '" + line + "'");
      element.count = static_cast<std::size_t>(count);
      elements.push_back(element);
    } else if (keyword == "property") {
      if (elements.empty()) throw Error("PLY '" + path + "': property before any element");
      Property property;
      std::string type;
      words >> type;
      if (type == "list") words >> property.count_type >> property.type >> property.name;
      else { property.type = type; words >> property.name; }
      typeSize(property.type, path);
      elements.back().properties.push_back(property);
    } else if (keyword == "end_header") {
      break;
    }
  }
  if (!stream) throw Error("PLY '" + path + "': header has no end_header");

  PlyTable table;
  ValueSource source(stream, binary, path);
  for (const Element& element : elements) {
    const bool is_vertex = element.name == "vertex";
    const bool is_face = element.name == "face";
    if (is_vertex) {
      table.vertex_count = element.count;
      for (const Property& p : element.properties) table.vertex_columns[p.name].reserve(element.count);
    }
    for (std::size_t row = 0; row < element.count; ++row) {
      for (const Property& property : element.properties) {
        if (property.count_type.empty()) {
          const double value = source.next(property.type);
          if (is_vertex) table.vertex_columns[property.name].push_back(value);
          continue;
        }
        const double count = source.next(property.count_type);
        if (count < 0 || count > 1e6) throw Error("PLY '" + path + "': implausible list length");
        std::vector<int> items(static_cast<std::size_t>(count));
        for (int& item : items) item = static_cast<int>(source.next(property.type));
        if (is_face && (property.name == "vertex_indices" || property.name == "vertex_index")) {
          table.faces.push_back(std::move(items));
        }
      }
    }
  }
  return table;
}

void writePlyTable(const std::string& path, const std::vector<std::string>& names,
                   const std::vector<const std::vector<double>*>& columns,
                   const std::vector<std::string>& byte_columns,
                   const std::vector<std::array<int, 3>>& faces) {
  const std::size_t rows = columns.empty() ? 0 : columns.front()->size();
  std::vector<bool> is_byte(names.size());
  std::ostringstream header;
  header << "ply\nformat binary_little_endian 1.0\ncomment written by dem_nerf\n"
         << "element vertex " << rows << "\n";
  for (std::size_t c = 0; c < names.size(); ++c) {
    is_byte[c] = std::find(byte_columns.begin(), byte_columns.end(), names[c]) != byte_columns.end();
    header << "property " << (is_byte[c] ? "uchar " : "float ") << names[c] << "\n";
  }
  if (!faces.empty()) header << "element face " << faces.size() << "\nproperty list uchar int vertex_indices\n";
  header << "end_header\n";

  // Temp file + rename: a reader never sees half a file, a full disk never eats the old one.
  const std::string temporary = path + ".tmp";
  {
    std::ofstream stream(temporary, std::ios::binary);
    if (!stream) throw Error("cannot write '" + path + "' (folder missing or not writable)");
    stream << header.str();
    std::vector<char> record;
    for (std::size_t row = 0; row < rows; ++row) {
      record.clear();
      for (std::size_t c = 0; c < names.size(); ++c) {
        const double value = (*columns[c])[row];
        if (is_byte[c]) {
          record.push_back(static_cast<char>(static_cast<std::uint8_t>(std::clamp(value, 0.0, 255.0))));
        } else {
          const float f = static_cast<float>(value);
          const char* bytes = reinterpret_cast<const char*>(&f);
          record.insert(record.end(), bytes, bytes + 4);
        }
      }
      stream.write(record.data(), static_cast<std::streamsize>(record.size()));
    }
    for (const auto& face : faces) {
      const std::uint8_t three = 3;
      stream.write(reinterpret_cast<const char*>(&three), 1);
      stream.write(reinterpret_cast<const char*>(face.data()), 12);
    }
    stream.flush();
    if (!stream) {
      stream.close();
      std::filesystem::remove(temporary);
      throw Error("writing '" + path + "' failed (disk full?); the previous file is untouched");
    }
  }
  std::filesystem::rename(temporary, path);
}

}  // namespace demnerf::core::detail
