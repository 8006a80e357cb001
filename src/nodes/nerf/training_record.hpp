#pragma once
// How far training had got when the model file was last written: a small text file beside the
// model (<model>.progress), so a restarted nerf_node continues the iteration count and the time
// budget instead of starting them again. The model file format itself stays untouched.

#include <cstdint>
#include <optional>
#include <string>

namespace dem_nerf {

struct TrainingRecord {
  std::int64_t iteration = 0;  ///< optimiser steps behind the saved weights, over every run
  double seconds = 0;          ///< training seconds behind them, likewise
  double psnr = 0;             ///< training PSNR (dB) when they were saved
};

/// <model_path>.progress
std::string trainingRecordPath(const std::string& model_path);

/// Written atomically (temporary file + rename) right after the model file; throws
/// demnerf::core::Error when it cannot be written.
void saveTrainingRecord(const std::string& model_path, const TrainingRecord& record);

/// Nothing when there is no record; throws demnerf::core::Error when it is malformed.
std::optional<TrainingRecord> loadTrainingRecord(const std::string& model_path);

}  // namespace dem_nerf
