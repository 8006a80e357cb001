#include "demnerf/nerf/background_trainer.hpp"

#include "demnerf/core/error.hpp"
#include "demnerf/nerf/model_io.hpp"

namespace demnerf::nerf {

BackgroundTrainer::BackgroundTrainer(std::unique_ptr<Trainer> trainer, const BackgroundTrainerConfig& config,
                                     BackgroundTrainerCallbacks callbacks)
    : trainer_(std::move(trainer)), config_(config), callbacks_(std::move(callbacks)), thread_([this] { run(); }) {}

BackgroundTrainer::~BackgroundTrainer() {
  stop();
  thread_.join();
}

void BackgroundTrainer::stop() {
  stop_wanted_ = true;
  trainer_->requestStop();
}

void BackgroundTrainer::save(const NerfModel& model, const TrainProgress& progress) {
  if (config_.model_path.empty()) return;
  const TrainingRecord record{config_.earlier.iteration + progress.iteration, config_.earlier.seconds + progress.seconds,
                              progress.psnr};
  try {
    saveModel(model, config_.model_path, record);
  } catch (const core::Error& error) {
    // A full disk must not end training: report it and keep the previous file.
    if (callbacks_.error) callbacks_.error(std::string("autosave failed: ") + error.what());
  }
}

void BackgroundTrainer::run() {
  try {
    const auto on_progress = [this](const TrainProgress& progress) {
      if (stop_wanted_) trainer_->requestStop();  // a stop() that came before train() began
      if (callbacks_.progress) callbacks_.progress(progress);
      // The callback runs between iterations on this thread, so the live model is consistent.
      if (config_.autosave_seconds > 0 && progress.seconds - last_save_ >= config_.autosave_seconds) {
        save(trainer_->model(), progress);
        last_save_ = progress.seconds;
      }
    };
    const TrainProgress final_progress = trainer_->train(config_.stop, on_progress, /*log=*/false);
    save(trainer_->model(), final_progress);
    if (callbacks_.done) callbacks_.done(trainer_->model(), final_progress);
  } catch (const std::exception& error) {
    if (callbacks_.error) callbacks_.error(std::string("training stopped: ") + error.what());
  }
  running_ = false;
}

}  // namespace demnerf::nerf
