#include "nodes/nerf/training_record.hpp"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "demnerf/core/error.hpp"

namespace dem_nerf {

using demnerf::core::Error;

std::string trainingRecordPath(const std::string& model_path) { return model_path + ".progress"; }

void saveTrainingRecord(const std::string& model_path, const TrainingRecord& record) {
  const std::string path = trainingRecordPath(model_path);
  const std::string temporary = path + ".tmp";
  {
    std::ofstream file(temporary, std::ios::trunc);
    file.precision(17);
    file << "iteration " << record.iteration << "\nseconds " << record.seconds << "\npsnr " << record.psnr << "\n";
    file.flush();
    if (!file) throw Error("cannot write the training record '" + temporary + "' (disk full or no permission?)");
  }
  std::error_code code;
  std::filesystem::rename(temporary, path, code);
  if (code) throw Error("cannot rename '" + temporary + "' to '" + path + "': " + code.message());
}

std::optional<TrainingRecord> loadTrainingRecord(const std::string& model_path) {
  const std::string path = trainingRecordPath(model_path);
  std::ifstream file(path);
  if (!file) return std::nullopt;
  TrainingRecord record;
  bool has_iteration = false, has_seconds = false;
  std::string key;
  while (file >> key) {
    if (key == "iteration") {
      has_iteration = static_cast<bool>(file >> record.iteration);
    } else if (key == "seconds") {
      has_seconds = static_cast<bool>(file >> record.seconds);
    } else if (key == "psnr") {
      file >> record.psnr;
    } else {
      throw Error("training record '" + path + "' has an unknown key '" + key + "'");
    }
    if (!file) break;
  }
  if (!has_iteration || !has_seconds || record.iteration < 0 || !std::isfinite(record.seconds) ||
      record.seconds < 0) {
    throw Error("training record '" + path + "' is malformed (needs 'iteration N' and 'seconds S', both >= 0)");
  }
  return record;
}

}  // namespace dem_nerf
