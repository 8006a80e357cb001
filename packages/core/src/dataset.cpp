#include "demnerf/core/dataset.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include "demnerf/core/error.hpp"
#include "demnerf/core/pose.hpp"
#include "detail/dataset_layouts.hpp"

namespace demnerf::core {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

Json readJson(const fs::path& path) {
  std::ifstream stream(path);
  if (!stream) throw Error("cannot open '" + path.string() + "'");
  try {
    return Json::parse(stream);
  } catch (const Json::exception& error) {
    throw Error("'" + path.string() + "' is not valid JSON: " + error.what());
  }
}

double number(const Json& object, const char* key, const fs::path& file) {
  const auto& value = object.at(key);
  if (!value.is_number() || !std::isfinite(value.get<double>())) {
    throw Error("'" + file.string() + "': key '" + key + "' must be a finite number, got " + value.dump());
  }
  return value.get<double>();
}

double numberOr(const Json& object, const Json& fallback, const char* key, double otherwise,
                const fs::path& file) {
  if (object.contains(key)) return number(object, key, file);
  if (fallback.contains(key)) return number(fallback, key, file);
  return otherwise;
}

// Image paths in NeRF-synthetic files often omit the extension ("./train/r_0").
fs::path resolveImagePath(const fs::path& root, const std::string& file_path) {
  fs::path path = root / file_path;
  if (fs::exists(path)) return path;
  for (const char* extension : {".png", ".jpg", ".jpeg", ".PNG", ".JPG"}) {
    fs::path candidate = path;
    candidate += extension;
    if (fs::exists(candidate)) return candidate;
  }
  return path;
}

// Intrinsics come from the frame when it has them (nerfstudio per-frame cameras), else from
// the file's top level; NeRF-synthetic files give only camera_angle_x and rely on image size.
PinholeCamera readCamera(const Json& frame, const Json& top, const fs::path& file,
                         const cv::Size& image_size) {
  PinholeCamera camera;
  camera.width = static_cast<int>(numberOr(frame, top, "w", image_size.width, file));
  camera.height = static_cast<int>(numberOr(frame, top, "h", image_size.height, file));
  if (camera.width <= 0 || camera.height <= 0) {
    throw Error("'" + file.string() + "': image size unknown (give w and h, or load the images)");
  }
  if (frame.contains("fl_x") || top.contains("fl_x")) {
    camera.fx = numberOr(frame, top, "fl_x", 0.0, file);
    camera.fy = numberOr(frame, top, "fl_y", camera.fx, file);
  } else if (frame.contains("camera_angle_x") || top.contains("camera_angle_x")) {
    const double angle = numberOr(frame, top, "camera_angle_x", 0.0, file);
    camera.fx = 0.5 * camera.width / std::tan(0.5 * angle);
    camera.fy = camera.fx;
    if (frame.contains("camera_angle_y") || top.contains("camera_angle_y")) {
      camera.fy = 0.5 * camera.height / std::tan(0.5 * numberOr(frame, top, "camera_angle_y", 0.0, file));
    }
  } else {
    throw Error("'" + file.string() + "': no focal length (need fl_x, per frame or at the top level, or "
                "camera_angle_x). Accepted: " + detail::kAcceptedLayouts);
  }
  camera.cx = numberOr(frame, top, "cx", 0.5 * camera.width, file);
  camera.cy = numberOr(frame, top, "cy", 0.5 * camera.height, file);
  camera.k1 = numberOr(frame, top, "k1", 0.0, file);
  camera.k2 = numberOr(frame, top, "k2", 0.0, file);
  camera.p1 = numberOr(frame, top, "p1", 0.0, file);
  camera.p2 = numberOr(frame, top, "p2", 0.0, file);
  camera.validate();
  return camera;
}

Eigen::Isometry3d readPose(const Json& frame, const fs::path& file, std::size_t index) {
  const std::string where = "'" + file.string() + "': frames[" + std::to_string(index) + "].transform_matrix";
  if (!frame.contains("transform_matrix")) throw Error(where + " is missing");
  const Json& rows = frame["transform_matrix"];
  if (!rows.is_array() || rows.size() < 3) throw Error(where + " must be a 4x4 (or 3x4) array");
  Eigen::Matrix4d matrix = Eigen::Matrix4d::Identity();
  for (int r = 0; r < static_cast<int>(rows.size()) && r < 4; ++r) {
    if (!rows[r].is_array() || rows[r].size() != 4) throw Error(where + " row " + std::to_string(r) + " must hold 4 numbers");
    for (int c = 0; c < 4; ++c) {
      if (!rows[r][c].is_number()) throw Error(where + " holds a non-number: " + rows[r][c].dump());
      matrix(r, c) = rows[r][c].get<double>();
    }
  }
  if (!matrix.allFinite()) throw Error(where + " holds NaN or Inf");
  if (!isRigidTransform(matrix, 0.05)) throw Error(where + " is not a rigid transform");
  return openGlToOptical(nearestRigidTransform(matrix));
}

std::vector<Frame> readFrames(const fs::path& file, const DatasetOptions& options, Json* top_out,
                              std::vector<std::string>* missing) {
  const Json top = readJson(file);
  if (!top.is_object() || !top.contains("frames") || !top["frames"].is_array()) {
    throw Error("'" + file.string() + "': expected an object with a 'frames' array. Accepted: " +
                detail::kAcceptedLayouts);
  }
  if (top["frames"].empty()) throw Error("'" + file.string() + "': 'frames' is empty");
  const fs::path root = file.parent_path();
  std::vector<Frame> frames;
  for (std::size_t i = 0; i < top["frames"].size(); ++i) {
    const Json& entry = top["frames"][i];
    if (!entry.contains("file_path") || !entry["file_path"].is_string()) {
      throw Error("'" + file.string() + "': frames[" + std::to_string(i) + "] has no file_path");
    }
    Frame frame;
    frame.file_path = entry["file_path"].get<std::string>();
    const fs::path image_path = resolveImagePath(root, frame.file_path);
    if (!fs::exists(image_path)) {
      missing->push_back(frame.file_path);
      continue;
    }
    frame.world_from_camera = readPose(entry, file, i);
    detail::checkCameraModel(entry, top, file, i);
    cv::Size image_size(0, 0);
    if (options.load_images) {
      frame.rgba = readImageRgba(image_path.string(), &frame.has_alpha);
      image_size = frame.rgba.size();
    } else if (!(entry.contains("w") || top.contains("w"))) {
      image_size = readImageRgba(image_path.string()).size();
    }
    frame.camera = readCamera(entry, top, file, image_size);
    if (!frame.rgba.empty() && frame.rgba.size() != cv::Size(frame.camera.width, frame.camera.height)) {
      throw Error("'" + image_path.string() + "' is " + std::to_string(frame.rgba.cols) + "x" +
                  std::to_string(frame.rgba.rows) + " but the transforms file says " +
                  std::to_string(frame.camera.width) + "x" + std::to_string(frame.camera.height));
    }
    if (options.downscale != 1.0) {
      frame.camera = frame.camera.downscaled(options.downscale);
      if (!frame.rgba.empty()) {
        cv::Mat small;
        cv::resize(frame.rgba, small, cv::Size(frame.camera.width, frame.camera.height), 0, 0, cv::INTER_AREA);
        frame.rgba = small;
      }
    }
    frames.push_back(std::move(frame));
  }
  if (frames.empty()) {
    throw Error("'" + file.string() + "': none of its " + std::to_string(top["frames"].size()) +
                " images exist (first: '" + top["frames"][0]["file_path"].get<std::string>() + "')");
  }
  if (top_out != nullptr) *top_out = top;
  return frames;
}

// The point nearest (in least squares) to every camera's optical axis: where they all look.
Eigen::Vector3d lookAtPoint(const std::vector<Frame>& frames) {
  Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (const Frame& frame : frames) {
    const Eigen::Vector3d d = frame.world_from_camera.linear().col(2);
    const Eigen::Matrix3d projector = Eigen::Matrix3d::Identity() - d * d.transpose();
    a += projector;
    b += projector * frame.world_from_camera.translation();
  }
  return a.ldlt().solve(b);
}

Eigen::AlignedBox3d sceneBounds(const Json& top, const std::vector<Frame>& frames, double aabb_scale,
                                const fs::path& file) {
  if (top.contains("aabb")) {
    const Json& aabb = top["aabb"];
    if (!aabb.is_array() || aabb.size() != 2 || aabb[0].size() != 3 || aabb[1].size() != 3) {
      throw Error("'" + file.string() + "': 'aabb' must be [[xmin,ymin,zmin],[xmax,ymax,zmax]]");
    }
    Eigen::AlignedBox3d box;
    box.min() = Eigen::Vector3d(aabb[0][0], aabb[0][1], aabb[0][2]);
    box.max() = Eigen::Vector3d(aabb[1][0], aabb[1][1], aabb[1][2]);
    if (!box.min().allFinite() || !box.max().allFinite() || (box.max().array() <= box.min().array()).any()) {
      throw Error("'" + file.string() + "': 'aabb' must have finite min < max");
    }
    return box;
  }
  if (top.contains("aabb_scale")) {
    // instant-ngp maps the scene with x' = 0.33 x + 0.5 into a unit cube grown aabb_scale times
    // about its centre; the same box in the file's own coordinates:
    const double half = 0.5 * aabb_scale / 0.33;
    return Eigen::AlignedBox3d(Eigen::Vector3d::Constant(-half), Eigen::Vector3d::Constant(half));
  }
  return boundsFromCameras(frames);
}

}  // namespace

Eigen::AlignedBox3d boundsFromCameras(const std::vector<Frame>& frames) {
  if (frames.empty()) throw Error("boundsFromCameras: no cameras");
  const Eigen::Vector3d centre = lookAtPoint(frames);
  double distance = 0.0;
  for (const Frame& frame : frames) distance += (frame.world_from_camera.translation() - centre).norm();
  const double half = 0.5 * distance / static_cast<double>(frames.size());
  return Eigen::AlignedBox3d(centre.array() - half, centre.array() + half);
}

const std::vector<Frame>& Dataset::split(const std::string& name) const {
  if (name == "train") return train;
  if (name == "test") return test;
  throw Error("unknown split '" + name + "' (use train or test)");
}

std::vector<Frame> Dataset::frames(const std::string& split_name) const {
  if (split_name != "all") return split(split_name);
  std::vector<Frame> all = train;
  all.insert(all.end(), test.begin(), test.end());
  return all;
}

Dataset loadDataset(const std::string& directory, const DatasetOptions& options) {
  const fs::path root(directory);
  if (!fs::is_directory(root)) throw Error("dataset folder '" + directory + "' does not exist");
  Dataset dataset;
  dataset.root = directory;
  Json top;
  if (fs::exists(root / "transforms_train.json")) {
    dataset.train = readFrames(root / "transforms_train.json", options, &top, &dataset.missing_images);
    if (fs::exists(root / "transforms_test.json")) {
      dataset.test = readFrames(root / "transforms_test.json", options, nullptr, &dataset.missing_images);
    }
  } else if (fs::exists(root / "transforms.json")) {
    std::vector<Frame> all = readFrames(root / "transforms.json", options, &top, &dataset.missing_images);
    for (std::size_t i = 0; i < all.size(); ++i) {
      const bool held_out = options.holdout_every > 0 && i % options.holdout_every == 0 && all.size() > 1;
      (held_out ? dataset.test : dataset.train).push_back(std::move(all[i]));
    }
  } else {
    throw Error(detail::unknownLayoutMessage(root));
  }
  const fs::path file = root / (fs::exists(root / "transforms_train.json") ? "transforms_train.json" : "transforms.json");
  dataset.layout = detail::detectLayout(top, file.filename().string());
  dataset.applied_transform = detail::readAppliedTransform(top, file);
  dataset.aabb_scale = top.contains("aabb_scale") ? number(top, "aabb_scale", file) : 1.0;
  dataset.bounds = sceneBounds(top, dataset.train, dataset.aabb_scale, file);
  return dataset;
}

void writeTransforms(const std::string& path, const std::vector<Frame>& frames,
                     const Eigen::AlignedBox3d& bounds) {
  if (frames.empty()) throw Error("writeTransforms: no frames to write to '" + path + "'");
  Json top;
  const PinholeCamera& first = frames.front().camera;
  auto writeIntrinsics = [](Json& object, const PinholeCamera& camera) {
    object["w"] = camera.width;
    object["h"] = camera.height;
    object["fl_x"] = camera.fx;
    object["fl_y"] = camera.fy;
    object["cx"] = camera.cx;
    object["cy"] = camera.cy;
    object["k1"] = camera.k1;
    object["k2"] = camera.k2;
    object["p1"] = camera.p1;
    object["p2"] = camera.p2;
    object["camera_angle_x"] = 2.0 * std::atan(0.5 * camera.width / camera.fx);
  };
  writeIntrinsics(top, first);
  top["aabb"] = {{bounds.min().x(), bounds.min().y(), bounds.min().z()},
                 {bounds.max().x(), bounds.max().y(), bounds.max().z()}};
  top["frames"] = Json::array();
  for (const Frame& frame : frames) {
    Json entry;
    entry["file_path"] = frame.file_path;
    const Eigen::Matrix4d matrix = opticalToOpenGl(frame.world_from_camera).matrix();
    for (int r = 0; r < 4; ++r) {
      entry["transform_matrix"].push_back({matrix(r, 0), matrix(r, 1), matrix(r, 2), matrix(r, 3)});
    }
    const PinholeCamera& c = frame.camera;
    const bool same = c.width == first.width && c.height == first.height && c.fx == first.fx &&
                      c.fy == first.fy && c.cx == first.cx && c.cy == first.cy;
    if (!same) writeIntrinsics(entry, c);
    top["frames"].push_back(entry);
  }
  const std::string temporary = path + ".tmp";
  {
    std::ofstream stream(temporary);
    stream << top.dump(2) << "\n";
    if (!stream) throw Error("cannot write '" + path + "' (folder missing or disk full?)");
  }
  fs::rename(temporary, path);
}

}  // namespace demnerf::core
