#pragma once
// Posed-image datasets in the transforms.json format (instant-ngp, nerfstudio, NeRF-synthetic).

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "demnerf/core/camera.hpp"

namespace demnerf::core {

/// One posed image. world_from_camera is the REP-103 optical frame (converted on load).
struct Frame {
  std::string file_path;  ///< as written in the transforms file (relative to the dataset)
  PinholeCamera camera;
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
  cv::Mat rgba;  ///< CV_32FC4, RGBA in [0, 1]; alpha is 1 where the image had none; empty if not loaded
  bool has_alpha = false;
};

struct DatasetOptions {
  double downscale = 1.0;    ///< 2 loads images at half width and height
  bool load_images = true;   ///< false reads poses and intrinsics only
  int holdout_every = 8;     ///< without transforms_test.json every Nth frame is held out
};

struct Dataset {
  std::string root;
  std::vector<Frame> train;
  std::vector<Frame> test;
  double aabb_scale = 1.0;  ///< instant-ngp's scene extent hint (1 when absent)
  Eigen::AlignedBox3d bounds;  ///< the scene box: from the file's "aabb" when present, else from the cameras
  /// Frames listed in the transforms file whose image does not exist; they are skipped (the
  /// instant-ngp fox lists 67 frames for its 50 photos), and callers should say so.
  std::vector<std::string> missing_images;
  std::string layout;  ///< "instant-ngp", "nerfstudio" or "nerf-synthetic"
  /// nerfstudio's applied_transform (times applied_scale): the map from the original capture's
  /// world (e.g. COLMAP's) into the world the file's poses are written in. The poses are
  /// already in that world and are used as written; this maps a box or points given in the
  /// original frame into it. Identity when the file has none.
  Eigen::Affine3d applied_transform = Eigen::Affine3d::Identity();

  const std::vector<Frame>& split(const std::string& name) const;  ///< "train" or "test"
  /// Copies of the frames of "train", "test" or "all" (train then test).
  std::vector<Frame> frames(const std::string& split_name) const;
};

/// Loads DIR/transforms.json (instant-ngp or nerfstudio: per-frame intrinsics override the
/// global ones; camera_model must be a pinhole one), or DIR/transforms_train.json (+
/// transforms_test.json, NeRF-synthetic). Throws core::Error naming the file, key and value
/// that are wrong, or for a folder in another layout, what it holds and how to convert it.
Dataset loadDataset(const std::string& directory, const DatasetOptions& options = {});

/// A scene box from the cameras alone: centred where their optical axes meet (least squares),
/// half the mean camera distance on each side. For rigs whose cameras surround the object.
Eigen::AlignedBox3d boundsFromCameras(const std::vector<Frame>& frames);

/// Writes a transforms file (OpenGL poses, per-frame intrinsics when cameras differ) whose
/// file_path entries are kept as given; the images themselves are written by the caller.
void writeTransforms(const std::string& path, const std::vector<Frame>& frames,
                     const Eigen::AlignedBox3d& bounds);

/// Reads an image file as CV_32FC4 RGBA in [0, 1]; sets has_alpha when the file had alpha.
cv::Mat readImageRgba(const std::string& path, bool* has_alpha = nullptr);
/// Writes a CV_32FC4 (RGBA) or CV_32FC3 (RGB) image in [0, 1] as 8-bit PNG.
void writeImagePng(const std::string& path, const cv::Mat& image);

}  // namespace demnerf::core
