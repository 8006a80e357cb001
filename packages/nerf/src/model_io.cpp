#include "demnerf/nerf/model_io.hpp"

#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>

#include "demnerf/core/error.hpp"
#include "demnerf/core/model_container.hpp"
#include "demnerf/nerf/training_record.hpp"

namespace demnerf::nerf {
namespace {

using core::Error;
constexpr core::ModelMagic kMagic = {'D', 'E', 'M', 'N', 'E', 'R', 'F', 'M'};
constexpr const char* kWhat = "NeRF model";

template <typename T>
void append(std::string& out, const T* data, std::size_t count) {
  out.append(reinterpret_cast<const char*>(data), count * sizeof(T));
}

nlohmann::json parseHeader(const core::ModelContainer& container, const std::string& where) {
  try {
    return nlohmann::json::parse(container.header);
  } catch (const nlohmann::json::exception& e) {
    throw Error(where + " is corrupt: header is not valid JSON (" + e.what() + ")");
  }
}

}  // namespace

std::optional<TrainingRecord> readTrainingRecord(const std::string& path) {
  const core::ModelContainer container = core::readModelContainer(path, kMagic, kModelFileVersion, kWhat);
  const std::string where = std::string(kWhat) + " file '" + path + "'";
  const nlohmann::json header = parseHeader(container, where);
  if (!header.contains("training")) return std::nullopt;
  TrainingRecord record;
  try {
    const nlohmann::json& t = header.at("training");
    record.iteration = t.at("iteration").get<std::int64_t>();
    record.seconds = t.at("seconds").get<double>();
    record.psnr = t.at("psnr").get<double>();
  } catch (const nlohmann::json::exception& e) {
    throw Error(where + ": its training record needs iteration, seconds and psnr (" + e.what() + ")");
  }
  if (record.iteration < 0 || !std::isfinite(record.seconds) || record.seconds < 0 || !std::isfinite(record.psnr))
    throw Error(where + ": its training record is malformed (iteration and seconds must be >= 0, all finite)");
  return record;
}

namespace {

void writeModel(const NerfModel& model, const std::string& path, const std::optional<TrainingRecord>& record) {
  const NgpField& f = model.ngp();
  const OccupancyGrid& g = model.grid();
  const Box box = model.bounds();
  nlohmann::json header;
  header["config"] = toJson(model.config());
  header["aabb_scale"] = model.aabbScale();
  header["bounds"] = {{box.min[0], box.min[1], box.min[2]}, {box.max[0], box.max[1], box.max[2]}};
  if (record) header["training"] = {{"iteration", record->iteration}, {"seconds", record->seconds}, {"psnr", record->psnr}};
  header["blobs"] = {
      {{"name", "hash_table"}, {"floats", f.table().size()}},
      {{"name", "density_mlp"}, {"floats", f.densityWeights().size()}},
      {{"name", "color_mlp"}, {"floats", f.colorWeights().size()}},
      {{"name", "occupancy_thickness"}, {"floats", g.thickness().size()}},
      {{"name", "occupancy_bits"}, {"bytes", g.bits().size()}},
  };
  core::ModelContainer container;
  container.version = kModelFileVersion;
  container.header = header.dump();
  std::string& out = container.payload;
  append(out, f.table().data(), f.table().size());
  append(out, f.densityWeights().data(), f.densityWeights().size());
  append(out, f.colorWeights().data(), f.colorWeights().size());
  append(out, g.thickness().data(), g.thickness().size());
  append(out, g.bits().data(), g.bits().size());
  core::writeModelContainer(path, kMagic, container, kWhat);
}

}  // namespace

void saveModel(const NerfModel& model, const std::string& path) { writeModel(model, path, std::nullopt); }

void saveModel(const NerfModel& model, const std::string& path, const TrainingRecord& record) {
  writeModel(model, path, record);
}

NerfModel loadModel(const std::string& path) {
  const core::ModelContainer container = core::readModelContainer(path, kMagic, kModelFileVersion, kWhat);
  const std::string where = std::string(kWhat) + " file '" + path + "'";
  const nlohmann::json header = parseHeader(container, where);
  std::vector<std::pair<std::string, std::size_t>> blobs;
  std::size_t expected = 0;
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
  if (container.payload.size() != expected) {
    throw Error(where + " is corrupt: its blobs need " + std::to_string(expected) + " bytes, the file holds " +
                std::to_string(container.payload.size()));
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
  NgpField& f = model.ngp();
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
  std::size_t offset = 0;
  for (std::size_t i = 0; i < blobs.size(); ++i) {
    if (blobs[i].first != targets[i].name) {
      throw Error(where + ": blob " + std::to_string(i) + " is '" + blobs[i].first + "', expected '" + targets[i].name + "'");
    }
    if (blobs[i].second != targets[i].bytes) {
      throw Error(where + ": '" + targets[i].name + "' has " + std::to_string(blobs[i].second) +
                  " bytes but its config implies " + std::to_string(targets[i].bytes));
    }
    std::memcpy(targets[i].dst, container.payload.data() + offset, targets[i].bytes);
    offset += targets[i].bytes;
  }
  f.refreshTransposed();
  return model;
}

}  // namespace demnerf::nerf
