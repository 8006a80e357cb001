#pragma once
// Runs a Trainer on its own thread, saving the model atomically every few seconds and when it
// stops, so a host (the ROS node) stays responsive and a restart loses little training.

#include <functional>
#include <memory>
#include <string>
#include <thread>

#include "demnerf/nerf/trainer.hpp"
#include "demnerf/nerf/training_record.hpp"

namespace demnerf::nerf {

struct BackgroundTrainerConfig {
  StopCriteria stop;              ///< when training ends (0 and 0: until stop())
  double autosave_seconds = 30;   ///< 0: save only at the end
  std::string model_path;         ///< where the model is saved (empty: never)
  /// Training behind the starting weights (a resumed model's record): the saved files' records
  /// continue from it.
  TrainingRecord earlier;
};

struct BackgroundTrainerCallbacks {
  ProgressCallback progress;                                         ///< about once a second
  std::function<void(const NerfModel&, const TrainProgress&)> done;  ///< after the final save
  std::function<void(const std::string&)> error;                     ///< training or saving failed
};

class BackgroundTrainer {
 public:
  BackgroundTrainer(std::unique_ptr<Trainer> trainer, const BackgroundTrainerConfig& config,
                    BackgroundTrainerCallbacks callbacks);
  /// Stops training and waits for the thread (the final save included).
  ~BackgroundTrainer();

  Trainer& trainer() { return *trainer_; }
  bool running() const { return running_; }
  /// Asks the thread to finish after the current iteration; returns at once.
  void stop();

 private:
  void run();
  void save(const NerfModel& model, const TrainProgress& progress);

  std::unique_ptr<Trainer> trainer_;
  BackgroundTrainerConfig config_;
  BackgroundTrainerCallbacks callbacks_;
  std::atomic<bool> running_{true};
  std::atomic<bool> stop_wanted_{false};  ///< survives train() resetting the trainer's own flag
  double last_save_ = 0;
  std::thread thread_;  // last: starts once everything above exists
};

}  // namespace demnerf::nerf
