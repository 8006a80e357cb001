#include "demnerf/nerf/model_io.hpp"

#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "demnerf/core/error.hpp"

namespace demnerf::nerf {
namespace {

using core::Error;
constexpr char kMagic[8] = {'D', 'E', 'M', 'N', 'E', 'R', 'F', 'M'};

std::uint64_t fnv1a(const char* data, std::size_t n) {
  std::uint64_t h = 1469598103934665603ull;
  for (std::size_t i = 0; i < n; ++i) {
    h ^= static_cast<unsigned char>(data[i]);
    h *= 1099511628211ull;
  }
  return h;
}

template <typename T>
void append(std::string& out, const T* data, std::size_t count) {
  out.append(reinterpret_cast<const char*>(data), count * sizeof(T));
}

struct Blob {
  const char* name;
  std::size_t bytes;
};

}  // namespace

void saveModel(const NerfModel& model, const std::string& path) {
  const NgpField& f = model.field();
  const OccupancyGrid& g = model.grid();
  const Box box = model.bounds();
  nlohmann::json header;
  header["config"] = toJson(model.config());
  header["aabb_scale"] = model.aabbScale();
  header["bounds"] = {{box.min[0], box.min[1], box.min[2]}, {box.max[0], box.max[1], box.max[2]}};
  header["blobs"] = {
      {{"name", "hash_table"}, {"floats", f.table().size()}},
      {{"name", "density_mlp"}, {"floats", f.densityWeights().size()}},
      {{"name", "color_mlp"}, {"floats", f.colorWeights().size()}},
      {{"name", "occupancy_thickness"}, {"floats", g.thickness().size()}},
      {{"name", "occupancy_bits"}, {"bytes", g.bits().size()}},
  };
  const std::string text = header.dump();
  std::string out;
  out.append(kMagic, sizeof(kMagic));
  const std::uint32_t version = kModelFileVersion;
  append(out, &version, 1);
  const std::uint64_t header_bytes = text.size();
  append(out, &header_bytes, 1);
  out += text;
  append(out, f.table().data(), f.table().size());
  append(out, f.densityWeights().data(), f.densityWeights().size());
  append(out, f.colorWeights().data(), f.colorWeights().size());
  append(out, g.thickness().data(), g.thickness().size());
  append(out, g.bits().data(), g.bits().size());
  const std::uint64_t checksum = fnv1a(out.data(), out.size());
  append(out, &checksum, 1);

  // Write next to the target and rename, so a crash or a full disk never leaves a torn file.
  const std::string tmp = path + ".tmp." + std::to_string(::getpid());
  {
    std::ofstream file(tmp, std::ios::binary | std::ios::trunc);
    if (!file) throw Error("cannot write model file '" + tmp + "' (does the directory exist and is it writable?)");
    file.write(out.data(), static_cast<std::streamsize>(out.size()));
    file.flush();
    if (!file) {
      file.close();
      std::remove(tmp.c_str());
      throw Error("writing model file '" + tmp + "' failed after " + std::to_string(out.size()) +
                  " bytes were queued (disk full?); '" + path + "' was left unchanged");
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const std::string reason = std::strerror(errno);
    std::remove(tmp.c_str());
    throw Error("cannot move model file into place at '" + path + "': " + reason);
  }
}

NerfModel loadModel(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  if (!file) throw Error("cannot open model file '" + path + "'");
  std::stringstream buffer;
  buffer << file.rdbuf();
  const std::string data = buffer.str();
  const std::string where = "model file '" + path + "'";
  const std::size_t fixed = sizeof(kMagic) + sizeof(std::uint32_t) + sizeof(std::uint64_t);
  if (data.size() < sizeof(kMagic) || std::memcmp(data.data(), kMagic, sizeof(kMagic)) != 0) {
    throw Error(where + " is not a dem_nerf NeRF model (wrong magic bytes)");
  }
  if (data.size() < fixed) throw Error(where + " is truncated: " + std::to_string(data.size()) + " bytes, no header");
  std::uint32_t version = 0;
  std::memcpy(&version, data.data() + sizeof(kMagic), sizeof(version));
  if (version != kModelFileVersion) {
    throw Error(where + " has format version " + std::to_string(version) + "; this build reads version " +
                std::to_string(kModelFileVersion));
  }
  std::uint64_t header_bytes = 0;
  std::memcpy(&header_bytes, data.data() + sizeof(kMagic) + sizeof(version), sizeof(header_bytes));
  if (header_bytes > data.size() - fixed) {
    throw Error(where + " is truncated: header says " + std::to_string(header_bytes) + " bytes, file has " +
                std::to_string(data.size()));
  }
  nlohmann::json header;
  try {
    header = nlohmann::json::parse(data.substr(fixed, header_bytes));
  } catch (const nlohmann::json::exception& e) {
    throw Error(where + " is corrupt: header is not valid JSON (" + e.what() + ")");
  }
  std::vector<std::pair<std::string, std::size_t>> blobs;
  std::size_t expected = fixed + header_bytes + sizeof(std::uint64_t);
  try {
    for (const auto& b : header.at("blobs")) {
      const std::size_t bytes = b.contains("floats") ? b["floats"].get<std::size_t>() * sizeof(float)
                                                     : b.at("bytes").get<std::size_t>();
      blobs.emplace_back(b.at("name").get<std::string>(), bytes);
      expected += bytes;
    }
  } catch (const nlohmann::json::exception& e) {
    throw Error(where + " is corrupt: header lacks its blob list (" + e.what() + ")");
  }
  if (data.size() < expected) {
    throw Error(where + " is truncated: expected " + std::to_string(expected) + " bytes, file has " +
                std::to_string(data.size()));
  }
  if (data.size() > expected) {
    throw Error(where + " is corrupt: " + std::to_string(data.size() - expected) + " unexpected bytes at the end");
  }
  std::uint64_t stored = 0;
  std::memcpy(&stored, data.data() + expected - sizeof(stored), sizeof(stored));
  if (fnv1a(data.data(), expected - sizeof(stored)) != stored) {
    throw Error(where + " is corrupt: checksum mismatch (the file was damaged after it was written)");
  }

  NerfConfig config = nerfConfigFromJson(header.at("config"));
  Box box;
  double aabb_scale = 1.0;
  try {
    for (int a = 0; a < 3; ++a) {
      box.min[a] = header.at("bounds").at(0).at(a).get<float>();
      box.max[a] = header.at("bounds").at(1).at(a).get<float>();
    }
    aabb_scale = header.at("aabb_scale").get<double>();
  } catch (const nlohmann::json::exception& e) {
    throw Error(where + " is corrupt: bad bounds or aabb_scale (" + e.what() + ")");
  }
  NerfModel model(config, box, aabb_scale);
  NgpField& f = model.field();
  OccupancyGrid& g = model.grid();
  struct Target {
    const char* name;
    char* dst;
    std::size_t bytes;
  };
  const Target targets[] = {
      {"hash_table", reinterpret_cast<char*>(f.table().data()), f.table().size() * sizeof(float)},
      {"density_mlp", reinterpret_cast<char*>(f.densityWeights().data()), f.densityWeights().size() * sizeof(float)},
      {"color_mlp", reinterpret_cast<char*>(f.colorWeights().data()), f.colorWeights().size() * sizeof(float)},
      {"occupancy_thickness", reinterpret_cast<char*>(g.thickness().data()), g.thickness().size() * sizeof(float)},
      {"occupancy_bits", reinterpret_cast<char*>(g.bits().data()), g.bits().size()},
  };
  if (blobs.size() != std::size(targets)) {
    throw Error(where + " holds " + std::to_string(blobs.size()) + " blobs, expected " + std::to_string(std::size(targets)));
  }
  std::size_t offset = fixed + header_bytes;
  for (std::size_t i = 0; i < blobs.size(); ++i) {
    if (blobs[i].first != targets[i].name) {
      throw Error(where + ": blob " + std::to_string(i) + " is '" + blobs[i].first + "', expected '" + targets[i].name + "'");
    }
    if (blobs[i].second != targets[i].bytes) {
      throw Error(where + ": '" + targets[i].name + "' has " + std::to_string(blobs[i].second) +
                  " bytes but its config implies " + std::to_string(targets[i].bytes));
    }
    std::memcpy(targets[i].dst, data.data() + offset, targets[i].bytes);
    offset += targets[i].bytes;
  }
  f.refreshTransposed();
  return model;
}

}  // namespace demnerf::nerf
