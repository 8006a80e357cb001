#pragma once
// How far training had got when a model file was written. It lives in the model file's header
// (saveModel), so the weights and their iteration count can never disagree, and a restarted
// nerf_node continues the count and the time budget instead of starting them again.

#include <cstdint>
#include <optional>
#include <string>

namespace demnerf::nerf {

class NerfModel;

struct TrainingRecord {
  std::int64_t iteration = 0;  ///< optimiser steps behind the saved weights, over every run
  double seconds = 0;          ///< training seconds behind them, likewise
  double psnr = 0;             ///< training PSNR (dB) when they were saved
};

/// The record in a model file's header; nothing for a file saved without one (`demnerf train`,
/// older files). Throws core::Error when the file is not a readable model file or its record is
/// malformed (negative or non-finite figures). Reads no weights into a model (no torch).
std::optional<TrainingRecord> readTrainingRecord(const std::string& model_path);

/// saveModel (model_io.hpp) with the record in the header; throws core::Error as it does.
void saveModel(const NerfModel& model, const std::string& path, const TrainingRecord& record);

}  // namespace demnerf::nerf
