#pragma once
// NeRF model files: config, scene box, weights and occupancy grid with a version and a
// checksum, written atomically (temporary file + rename).

#include <string>

#include "demnerf/nerf/model.hpp"

namespace demnerf::nerf {

/// The file format version this build writes and reads.
constexpr int kModelFileVersion = 1;

/// Throws core::Error when the file cannot be written (the previous file, if any, is kept).
void saveModel(const NerfModel& model, const std::string& path);
/// Throws core::Error naming what is wrong: not a model file, unsupported version, truncated,
/// corrupt (checksum), or weights whose shapes disagree with the stored config.
NerfModel loadModel(const std::string& path);

}  // namespace demnerf::nerf
