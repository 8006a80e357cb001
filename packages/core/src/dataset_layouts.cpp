#include "detail/dataset_layouts.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "demnerf/core/error.hpp"

namespace demnerf::core::detail {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

bool isImage(const fs::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext == ".png" || ext == ".jpg" || ext == ".jpeg";
}

int countImages(const fs::path& folder) {
  if (!fs::is_directory(folder)) return 0;
  int count = 0;
  for (const auto& entry : fs::directory_iterator(folder)) count += entry.is_regular_file() && isImage(entry.path());
  return count;
}

bool hasColmapModel(const fs::path& root) {
  for (const char* sub : {"sparse/0", "sparse", "colmap/sparse/0", "colmap/sparse"}) {
    for (const char* name : {"cameras.bin", "cameras.txt"}) {
      if (fs::exists(root / sub / name)) return true;
    }
  }
  return false;
}

}  // namespace

const char* const kAcceptedLayouts =
    "instant-ngp transforms.json (frames with file_path + transform_matrix, intrinsics fl_x/fl_y/cx/cy/w/h or "
    "camera_angle_x); nerfstudio transforms.json (the same, with camera_model PINHOLE/OPENCV, optional per-frame "
    "intrinsics and applied_transform); NeRF-synthetic transforms_train.json (+ transforms_test.json)";

std::string detectLayout(const Json& top, const std::string& file_name) {
  if (file_name == "transforms_train.json") return "nerf-synthetic";
  if (top.contains("camera_model") || top.contains("applied_transform")) return "nerfstudio";
  if (top.contains("frames") && top["frames"].is_array()) {
    for (const Json& frame : top["frames"]) {
      if (frame.is_object() && (frame.contains("fl_x") || frame.contains("camera_model"))) return "nerfstudio";
    }
  }
  return "instant-ngp";
}

void checkCameraModel(const Json& frame, const Json& top, const fs::path& file, std::size_t index) {
  const Json& source = frame.contains("camera_model") ? frame : top;
  if (source.contains("camera_model")) {
    const Json& model = source["camera_model"];
    const std::string name = model.is_string() ? model.get<std::string>() : model.dump();
    // The perspective models nerfstudio writes; all are pinhole + (a subset of) k1 k2 p1 p2.
    static const std::vector<std::string> kPerspective = {"PINHOLE", "SIMPLE_PINHOLE", "OPENCV", "SIMPLE_RADIAL",
                                                          "RADIAL"};
    if (std::find(kPerspective.begin(), kPerspective.end(), name) == kPerspective.end()) {
      throw Error("'" + file.string() + "': frames[" + std::to_string(index) + "] has camera_model " + name +
                  ", which demnerf cannot model; accepted: PINHOLE, SIMPLE_PINHOLE, OPENCV, SIMPLE_RADIAL, RADIAL "
                  "(pinhole with k1 k2 p1 p2). Undistort the images to a pinhole camera first (e.g. "
                  "`ns-process-data` or COLMAP's image_undistorter) and write camera_model PINHOLE");
    }
  }
  for (const char* key : {"k3", "k4"}) {
    const Json& holder = frame.contains(key) ? frame : top;
    if (!holder.contains(key)) continue;
    const Json& value = holder[key];
    if (!value.is_number()) throw Error("'" + file.string() + "': key '" + key + "' must be a number, got " + value.dump());
    if (value.get<double>() != 0.0) {
      throw Error("'" + file.string() + "': frames[" + std::to_string(index) + "] has " + key + " = " + value.dump() +
                  "; demnerf's lens model has k1 k2 p1 p2 only. Undistort the images (and set " + key +
                  " to 0) or re-calibrate with the OPENCV model");
    }
  }
}

Eigen::Affine3d readAppliedTransform(const Json& top, const fs::path& file) {
  Eigen::Affine3d applied = Eigen::Affine3d::Identity();
  if (!top.contains("applied_transform")) return applied;
  const std::string where = "'" + file.string() + "': applied_transform";
  const Json& rows = top["applied_transform"];
  if (!rows.is_array() || (rows.size() != 3 && rows.size() != 4)) throw Error(where + " must be a 3x4 (or 4x4) array");
  for (int r = 0; r < 3; ++r) {
    if (!rows[r].is_array() || rows[r].size() != 4) throw Error(where + " row " + std::to_string(r) + " must hold 4 numbers");
    for (int c = 0; c < 4; ++c) {
      if (!rows[r][c].is_number()) throw Error(where + " holds a non-number: " + rows[r][c].dump());
      applied.matrix()(r, c) = rows[r][c].get<double>();
    }
  }
  if (!applied.matrix().allFinite() || std::abs(applied.linear().determinant()) < 1e-12) {
    throw Error(where + " must be finite and invertible");
  }
  if (top.contains("applied_scale")) {
    const Json& scale = top["applied_scale"];
    if (!scale.is_number() || !(scale.get<double>() > 0.0) || !std::isfinite(scale.get<double>())) {
      throw Error("'" + file.string() + "': applied_scale must be a positive number, got " + scale.dump());
    }
    applied = Eigen::Scaling(scale.get<double>()) * applied;
  }
  return applied;
}

std::string unknownLayoutMessage(const fs::path& root) {
  std::string message = "'" + root.string() + "' holds no transforms.json or transforms_train.json. Accepted: " +
                        kAcceptedLayouts + ". ";
  if (hasColmapModel(root)) {
    return message + "It holds a COLMAP model: convert it with nerfstudio's `ns-process-data images` (or "
                     "instant-ngp's colmap2nerf.py), which writes transforms.json";
  }
  if (fs::exists(root / "poses_bounds.npy")) {
    return message + "It holds LLFF poses (poses_bounds.npy), which demnerf does not read: convert them to a "
                     "transforms.json (camera-to-world OpenGL matrices per image)";
  }
  std::vector<std::string> jsons;
  for (const auto& entry : fs::directory_iterator(root)) {
    if (entry.is_regular_file() && entry.path().extension() == ".json") jsons.push_back(entry.path().filename().string());
  }
  if (!jsons.empty()) {
    std::string names;
    for (const std::string& name : jsons) names += (names.empty() ? "" : ", ") + name;
    return message + "It holds " + names + ": name the pose file transforms.json (or transforms_train.json)";
  }
  const int images = countImages(root) + countImages(root / "images");
  if (images > 0) {
    return message + "It holds " + std::to_string(images) + " images but no camera poses: estimate them first "
           "(nerfstudio's `ns-process-data images --data " + root.string() + "` runs COLMAP and writes transforms.json)";
  }
  return message + "The folder holds neither images nor a pose file";
}

}  // namespace demnerf::core::detail
