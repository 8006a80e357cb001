// dem_node's reporting: errors counted by cause, the status message (on every change and once a
// second) with the running solve's progress.
#include <dem_nerf/TrainingStatus.h>

#include <sstream>

#include "nodes/dem/dem_node.hpp"

namespace dem_nerf {

void DemNode::reportError(const std::string& cause, const std::string& message) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    last_error_ = message;
  }
  rejections_.count(cause, message);
  publishStatus("error", message);
}

void DemNode::reportSolveFailure(const SolveJob& job, const std::string& cause, const std::string& message) {
  // The last good solution stays published; the error says why this one failed.
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stage_ = "error";
    solve_running_ = false;
  }
  reportError(cause, job.cause + " not solved: " + message);
}

void DemNode::publishStatus(const std::string& stage, const std::string& message) {
  dem_nerf::TrainingStatus status;
  status.header.stamp = ros::Time::now();
  status.stage = stage;
  status.message = message;
  status.rejections = rejections_.counts();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    status.particles = particles_ ? static_cast<std::uint32_t>(particles_->size()) : 0;
    status.renders = static_cast<std::uint32_t>(renders_);
    status.last_solve = last_answer_;
    status.solve.running = solve_running_;
    status.solve.time_limit = solve_time_limit_;
    if (solve_running_) {
      status.solve.solver = solve_progress_.solver;
      status.solve.phase = solve_progress_.phase;
      status.solve.load_fraction = solve_progress_.load_fraction;
      status.solve.iteration = static_cast<std::uint32_t>(std::max(solve_progress_.iteration, 0));
      status.solve.energy = solve_progress_.energy;
      status.solve.residual = solve_progress_.residual;
      status.solve.elapsed =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - solve_started_).count();
    }
  }
  status_publisher_.publish(status);
}

void DemNode::publishPeriodicStatus(const ros::TimerEvent&) {
  try {
    std::string stage, message;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stage = stage_;
      message = (particles_ ? std::to_string(particles_->size()) + " particles" : std::string("no particles yet")) +
                (last_figures_.empty() ? "" : "; last solve: " + last_figures_) +
                (config_.render_frame.empty() ? ""
                                              : "; " + std::to_string(renders_) + " renders" +
                                                    (last_render_.empty() ? "" : " (last " + last_render_ + ")")) +
                (last_error_.empty() ? "" : "; last error: " + last_error_);
      if (solve_running_) {
        std::ostringstream text;
        text.precision(3);
        text << "; solving (" << solve_progress_.phase << ", load " << solve_progress_.load_fraction << ", iteration "
             << solve_progress_.iteration << ", "
             << std::chrono::duration<double>(std::chrono::steady_clock::now() - solve_started_).count() << " s of "
             << solve_time_limit_ << " s)";
        message += text.str();
      }
    }
    publishStatus(stage, message);
  } catch (const std::exception& error) {
    ROS_ERROR_THROTTLE(5.0, "dem_node: status not published: %s", error.what());
  }
}

}  // namespace dem_nerf
