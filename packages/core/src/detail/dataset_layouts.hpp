#pragma once
// What distinguishes the transforms.json dialects the loader accepts (instant-ngp, nerfstudio,
// NeRF-synthetic), and the diagnosis of a folder that holds none of them.

#include <Eigen/Geometry>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

namespace demnerf::core::detail {

/// The layouts the loader reads, for error messages and `demnerf info`.
extern const char* const kAcceptedLayouts;

/// "nerf-synthetic", "nerfstudio" or "instant-ngp", from the file's name and keys.
std::string detectLayout(const nlohmann::json& top, const std::string& file_name);

/// Rejects a camera the pinhole + Brown (k1 k2 p1 p2) model cannot represent: a camera_model
/// other than the perspective ones (per frame or global), or non-zero k3 / k4.
void checkCameraModel(const nlohmann::json& frame, const nlohmann::json& top, const std::filesystem::path& file,
                      std::size_t index);

/// nerfstudio's applied_transform (3x4 or 4x4, optionally scaled by applied_scale): the map
/// from the original (e.g. COLMAP) world into the world the file's poses are written in.
/// Identity when absent; core::Error when malformed.
Eigen::Affine3d readAppliedTransform(const nlohmann::json& top, const std::filesystem::path& file);

/// The message for a folder without transforms.json / transforms_train.json: which layouts are
/// accepted, and what the folder looks like instead (COLMAP model, LLFF poses, bare images).
std::string unknownLayoutMessage(const std::filesystem::path& root);

}  // namespace demnerf::core::detail
