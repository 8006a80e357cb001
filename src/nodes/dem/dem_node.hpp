#pragma once
// dem_node: takes the particle cloud, fixtures and loads, solves the quasi-static deformation
// in a worker thread and publishes the displaced cloud; while someone subscribes to ~rendered
// and ~render_frame is set, a second worker renders each result through the NeRF. All
// algorithms live in packages/; this class only wires them to ROS.

#include <dem_nerf/FixtureArray.h>
#include <dem_nerf/LoadCase.h>
#include <dem_nerf/ModelInfo.h>
#include <dem_nerf/Solve.h>
#include <dem_nerf/SolveAnswer.h>
#include <geometry_msgs/WrenchStamped.h>
#include <image_transport/image_transport.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <ros/callback_queue.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <future>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "demnerf/core/ply.hpp"
#include "demnerf/core/scenario.hpp"
#include "demnerf/mechanics/dem_session.hpp"
#include "demnerf/mechanics/patch_response.hpp"
#include "demnerf/mechanics/simulate.hpp"
#include "demnerf/mechanics/solve_control.hpp"
#include "nodes/common/rejection_counter.hpp"
#include "nodes/dem/deformed_view.hpp"
#include "nodes/dem/dem_node_config.hpp"
#include "nodes/dem/interactive_push.hpp"
#include "nodes/dem/live_settings.hpp"
#include "nodes/dem/solution_export.hpp"
#include "workers/latest_wins_worker.hpp"

namespace dem_nerf {

class DemNode {
 public:
  DemNode(ros::NodeHandle node, ros::NodeHandle private_node, const DemNodeConfig& config);
  /// Cancels a running solve and answers a waiting ~solve caller before the workers stop.
  ~DemNode();

 private:
  /// What one solve needs; a newer one replaces a waiting one (bursts coalesce).
  struct SolveJob {
    demnerf::core::ParticleCloud cloud;
    std::uint64_t cloud_generation = 0;  ///< which particle message the cloud came from
    demnerf::core::Scenario scenario;
    std::string cause;  ///< "wrench", "load case", ... for the status message
    LiveSolveSettings settings;  ///< solver, options and material when the job was made
    /// Set for a ~solve call: its caller waits for this (an outcome or the error).
    std::shared_ptr<std::promise<demnerf::mechanics::SimulationOutcome>> reply;
  };
  /// How a job was answered: the figures for ~status's last_solve, and the same in words for its
  /// message ("instant (patch basis, 2 ms)").
  struct SolveReport {
    dem_nerf::SolveAnswer figures;
    std::string how;
  };
  /// One image for ~rendered: a newer result replaces one not rendered yet.
  struct RenderJob {
    demnerf::core::ResultField result;
    ros::Time stamp;
  };

  void onParticles(const sensor_msgs::PointCloud2ConstPtr& message);
  void onFixtures(const dem_nerf::FixtureArrayConstPtr& message);
  void onWrench(const geometry_msgs::WrenchStampedConstPtr& message);
  void onLoadCase(const dem_nerf::LoadCaseConstPtr& message);
  void onModel(const dem_nerf::ModelInfoConstPtr& message);
  void onRenderCameraInfo(const sensor_msgs::CameraInfoConstPtr& message);
  // dem_node_live.cpp: the live settings and, with ~interactive, the push markers.
  void startLiveSettings(const ros::NodeHandle& private_node);
  /// The push marker's load becomes the only load, and is solved.
  void onPushLoad(const demnerf::core::Load& load);
  /// The fixture box replaces the first fixture when it holds particles, and is solved.
  void onFixtureBox(const Eigen::Vector3d& center, const Eigen::Vector3d& size);
  /// With ~patch_basis_force_range: a one-load DEM job answered through the patch basis
  /// (prepared on the first wrench on a patch), or nothing when it does not apply.
  std::optional<demnerf::mechanics::SimulationOutcome> solveWithPatchBasis(
      const SolveJob& job, const demnerf::mechanics::SolveControl& control, SolveReport& report);
  /// A new ~rendered subscriber gets the latest result rendered at once.
  void onRenderSubscriber(const image_transport::SingleSubscriberPublisher&);
  bool solve(dem_nerf::Solve::Request& request, dem_nerf::Solve::Response& response);

  /// The current scenario with a load case's fixtures and loads; throws core::Error saying what
  /// is wrong (no material, no particles, a region that selects nothing, NaN).
  demnerf::core::Scenario scenarioFor(const dem_nerf::LoadCase& load_case);
  /// Queues a solve of the current state when particles and a scenario are there.
  void requestSolve(const std::string& cause);
  /// Queues the job; a replaced job's ~solve caller is answered "superseded", and a solve that has
  /// run longer than ~supersede_after (and serves no ~solve caller) is cancelled.
  void submitSolve(SolveJob job);
  void runSolve(const SolveJob& job);
  demnerf::mechanics::SimulationOutcome solveJob(const SolveJob& job, SolveReport& report);
  /// The DEM solve of a job through dem_session_; the report says instant / warm / cold.
  demnerf::mechanics::SimulationOutcome solveWithSession(const SolveJob& job,
                                                         const demnerf::mechanics::SolveControl& control,
                                                         SolveReport& report);
  /// Counts a failed solve by its cause (SolveError's failure, or the exception kind).
  void reportSolveFailure(const SolveJob& job, const std::string& cause, const std::string& message);
  /// Transforms a cloud from its message frame into ~particles_frame through tf (or refuses).
  void toParticlesFrame(demnerf::core::ParticleCloud& cloud, const std_msgs::Header& header);
  /// Regions of fixtures and load cases are read in ~particles_frame: another frame is refused.
  void requireParticlesFrame(const std::string& frame_id, const std::string& what) const;
  void publishResult(const demnerf::mechanics::SimulationOutcome& outcome, const demnerf::core::Scenario& scenario);
  /// Keeps the result for later subscribers and queues a render when someone listens.
  void requestRender(const demnerf::core::ResultField& result);
  void runRender(const RenderJob& job);
  void publishStatus(const std::string& stage, const std::string& message);
  /// Counts the refusal under `cause`, logs it (once per cause per interval), keeps it as the
  /// last error and publishes it on ~status at once.
  void reportError(const std::string& cause, const std::string& message);
  void publishPeriodicStatus(const ros::TimerEvent&);

  DemNodeConfig config_;
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  ros::Subscriber particles_subscriber_, fixtures_subscriber_, wrench_subscriber_, load_case_subscriber_,
      model_subscriber_, render_camera_info_subscriber_;
  ros::Publisher displaced_publisher_, markers_publisher_, status_publisher_;
  image_transport::Publisher rendered_publisher_;
  ros::ServiceServer solve_service_;
  ros::Timer status_timer_;
  RejectionCounter rejections_{"dem_node"};
  /// Set to stop the running solve (superseded, or shutdown); cleared when a solve starts.
  std::atomic<bool> cancel_{false};
  std::atomic<bool> shutting_down_{false};

  std::mutex mutex_;  // guards everything below
  std::optional<demnerf::core::ParticleCloud> particles_;
  demnerf::core::Scenario scenario_;  ///< material and current fixtures/loads
  bool scenario_loaded_ = false;
  std::string stage_ = "idle";
  std::string last_error_;
  std::string last_figures_;
  dem_nerf::SolveAnswer last_answer_;  ///< ~status's last_solve (sequence 0: nothing answered yet)
  std::string model_info_path_, model_info_frame_;  ///< from the last ModelInfo on `model`
  std::optional<demnerf::core::PinholeCamera> render_camera_;  ///< from ~render_camera_info
  std::optional<demnerf::core::ResultField> last_result_;      ///< what a new subscriber sees
  std::size_t renders_ = 0;
  std::string last_render_;
  // The running solve, for ~status and for superseding it.
  bool solve_running_ = false;
  bool solve_has_reply_ = false;
  std::chrono::steady_clock::time_point solve_started_;
  demnerf::mechanics::SolveProgress solve_progress_;
  double solve_time_limit_ = 0.0;  ///< of the running (or last) solve, for ~status
  std::optional<SolveJob> deferred_;  ///< a topic's job that waits for a ~solve job to start

  DeformedView view_;  ///< only the render worker's thread touches it
  SolutionExport export_{config_.export_dir};  ///< ~export_dir; only the solve worker's thread touches it
  // The workers come last (their threads use the members above); the solve worker is destroyed
  // first because its thread queues renders.
  std::uint64_t particles_generation_ = 0;  ///< counts accepted particle clouds (guarded by mutex_)
  // The DEM kept across solves (warm starts, instant parametric answers); worker thread only.
  std::unique_ptr<demnerf::mechanics::DemSession> dem_session_;
  std::uint64_t session_generation_ = 0;
  std::uint64_t session_model_generation_ = 0;  ///< the live settings' model_generation it was made for
  // The patch basis (worker thread only): its range (force 0: off) and what it was prepared for.
  demnerf::mechanics::PatchResponseConfig patch_basis_config_{0.0, 0.0, true};
  std::unique_ptr<demnerf::mechanics::PatchResponse> patch_basis_;
  std::uint64_t patch_basis_cloud_ = 0, patch_basis_model_ = 0;

  std::unique_ptr<LatestWinsWorker<RenderJob>> render_worker_;
  std::unique_ptr<LatestWinsWorker<SolveJob>> worker_;
  // ~solve waits for the worker on its own queue and thread, so the status timer and the topics
  // on the global queue never wait behind it. Last: stopped first.
  ros::CallbackQueue service_queue_;
  std::unique_ptr<ros::AsyncSpinner> service_spinner_;
  // Their callbacks ask for solves: made before the service and the subscribers.
  std::unique_ptr<LiveSettings> live_;
  std::unique_ptr<InteractivePush> push_;  ///< only with ~interactive
};

}  // namespace dem_nerf
