#pragma once
// nerf_node: collects posed keyframes from the rig's cameras, trains the NeRF on them in a
// worker thread, and publishes what the simulation needs (particles, mesh, model). All
// algorithms live in packages/; this class only wires them to ROS.

#include <dem_nerf/ExtractParticles.h>
#include <dem_nerf/LoadModel.h>
#include <dem_nerf/RenderView.h>
#include <dem_nerf/SaveModel.h>
#include <diagnostic_updater/diagnostic_updater.h>
#include <image_transport/image_transport.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "demnerf/nerf/background_trainer.hpp"
#include "demnerf/nerf/config.hpp"
#include "demnerf/nerf/training_record.hpp"
#include "nodes/common/rejection_counter.hpp"
#include "nodes/nerf/frame_intake.hpp"
#include "nodes/nerf/nerf_node_config.hpp"

namespace dem_nerf {

class NerfNode {
 public:
  NerfNode(ros::NodeHandle node, ros::NodeHandle private_node, const NerfNodeConfig& config);
  /// Stops training; the background trainer saves the model one last time.
  ~NerfNode();

 private:
  void onImage(const std::string& camera, const sensor_msgs::ImageConstPtr& image,
               const sensor_msgs::CameraInfoConstPtr& info);
  void pollFrames(const ros::TimerEvent&);
  void startTraining();  // with mutex_ held
  void onTrained(const demnerf::nerf::NerfModel& model, const demnerf::nerf::TrainProgress& progress);
  /// On the training thread, between iterations: the model file, then its training record.
  void autosave(const demnerf::nerf::NerfModel& model, const demnerf::nerf::TrainProgress& progress);
  /// This session's progress counted from the start of the first run (adds resumed_).
  demnerf::nerf::TrainProgress overAllRuns(demnerf::nerf::TrainProgress progress);  // with mutex_ held
  void publishModel(std::shared_ptr<const demnerf::nerf::NerfModel> model, std::uint32_t iteration, float psnr);
  void publishStatus(const ros::TimerEvent&);
  void publishPreview();
  /// Counts the refusal under `cause`, logs it (once per cause per interval), keeps it as the
  /// last error and publishes it on ~status at once.
  void reportError(const std::string& cause, const std::string& message);
  void fillDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& status);
  /// The trained model, or a snapshot of the one in training; null before training starts.
  std::shared_ptr<const demnerf::nerf::NerfModel> currentModel();
  /// ~extraction with the keyframes' cameras attached when it carves (~extraction/solid_views):
  /// what `demnerf extract --solid-cameras DIR` attaches from the capture's training split.
  SurfaceConfig extractionConfig();

  bool render(dem_nerf::RenderView::Request& request, dem_nerf::RenderView::Response& response);
  bool extract(dem_nerf::ExtractParticles::Request& request, dem_nerf::ExtractParticles::Response& response);
  bool save(dem_nerf::SaveModel::Request& request, dem_nerf::SaveModel::Response& response);
  bool load(dem_nerf::LoadModel::Request& request, dem_nerf::LoadModel::Response& response);
  bool reset(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& response);

  NerfNodeConfig config_;
  demnerf::nerf::NerfConfig nerf_config_;
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  FrameIntake intake_;
  image_transport::ImageTransport transport_;
  std::vector<image_transport::CameraSubscriber> camera_subscribers_;
  ros::Publisher status_publisher_, particles_publisher_, mesh_publisher_, model_publisher_;
  image_transport::Publisher preview_publisher_;
  std::vector<ros::ServiceServer> services_;
  ros::Timer status_timer_, poll_timer_;
  RejectionCounter rejections_{"nerf_node"};
  diagnostic_updater::Updater diagnostics_;

  std::mutex mutex_;  // guards everything below
  std::vector<demnerf::core::Frame> keyframes_;
  std::unique_ptr<demnerf::nerf::BackgroundTrainer> background_;
  std::unique_ptr<demnerf::nerf::NerfModel> resume_from_;  ///< a saved model training continues from
  demnerf::nerf::TrainingRecord resumed_;   ///< iterations and seconds behind resume_from_ (zero for a fresh model)
  std::string resume_note_;  ///< what was resumed, for ~status
  double last_autosave_ = 0; ///< session seconds of the last autosave (training thread only)
  std::shared_ptr<const demnerf::nerf::NerfModel> trained_;
  demnerf::nerf::TrainProgress progress_;
  std::string stage_ = "waiting_for_frames";
  std::string last_error_;
  ros::WallTime last_preview_;
  std::map<std::string, std::uint32_t> last_sequence_;  ///< per camera: the last image's header.seq

  // The services (a render takes seconds) run on their own queue and thread, so that the status
  // timer and the image intake on the global queue never wait behind them. Last: stopped first.
  ros::CallbackQueue service_queue_;
  std::unique_ptr<ros::AsyncSpinner> service_spinner_;
};

}  // namespace dem_nerf
