// dem_node's render side: the deformed NeRF on ~rendered, computed on its own worker and only
// while someone listens.
#include <tf2_eigen/tf2_eigen.h>

#include <sstream>

#include "conversions/camera_info_conversions.hpp"
#include "conversions/image_conversions.hpp"
#include "demnerf/core/error.hpp"
#include "demnerf/mechanics/process_settings.hpp"
#include "nodes/dem/dem_node.hpp"

namespace dem_nerf {

using demnerf::core::Error;

void DemNode::onModel(const dem_nerf::ModelInfoConstPtr& message) {
  try {
    std::optional<demnerf::core::ResultField> result;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      model_info_path_ = message->model_path;
      model_info_frame_ = message->header.frame_id;
      result = last_result_;
    }
    if (result) requestRender(*result);  // a newer model changes how the current result looks
  } catch (const std::exception& error) {
    reportError("model", std::string("model info: ") + error.what());
  }
}

void DemNode::onRenderCameraInfo(const sensor_msgs::CameraInfoConstPtr& message) {
  try {
    const std::uint64_t pixels = std::uint64_t(message->width) * message->height;
    if (pixels > static_cast<std::uint64_t>(config_.max_render_pixels))
      throw Error(std::to_string(message->width) + "x" + std::to_string(message->height) +
                  " is more than ~max_render_pixels = " + std::to_string(config_.max_render_pixels) + " pixels");
    const demnerf::core::PinholeCamera camera = fromCameraInfo(*message);
    std::lock_guard<std::mutex> lock(mutex_);
    render_camera_ = camera;
  } catch (const std::exception& error) {
    reportError("render_camera_info", std::string("render camera_info rejected: ") + error.what());
  } catch (...) {
    reportError("render_camera_info", "render camera_info rejected: unknown exception");
  }
}

void DemNode::onRenderSubscriber(const image_transport::SingleSubscriberPublisher&) {
  std::optional<demnerf::core::ResultField> result;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    result = last_result_;
  }
  if (result) requestRender(*result);
}

void DemNode::requestRender(const demnerf::core::ResultField& result) {
  if (config_.render_frame.empty()) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    last_result_ = result;
  }
  // Compute only when someone listens (image_pipeline style): a render costs about a second.
  if (rendered_publisher_.getNumSubscribers() == 0) return;
  RenderJob job;
  job.result = result;
  job.stamp = ros::Time::now();
  render_worker_->submit(std::move(job));
}

void DemNode::runRender(const RenderJob& job) {
  if (rendered_publisher_.getNumSubscribers() == 0) return;  // the listener left while this waited
  try {
    std::string model_path, model_frame;
    std::optional<demnerf::core::PinholeCamera> camera;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      model_path = model_info_path_.empty() ? config_.model_path : model_info_path_;
      model_frame = model_info_frame_;
      camera = render_camera_;
    }
    if (model_path.empty()) {
      throw Error("no NeRF model to render with: no ModelInfo on 'model' yet and no ~model_path set");
    }
    if (!model_frame.empty() && model_frame != config_.particles_frame) {
      throw Error("the NeRF model is in frame '" + model_frame + "' but ~particles_frame is '" +
                  config_.particles_frame + "'");
    }
    {
      // Loading may evaluate the model: torch matmuls, OpenBLAS calls the solve must not shut down under.
      const demnerf::mechanics::BlasCallsInFlight blas_calls;
      view_.useModel(model_path);
    }
    if (!camera) camera = cameraFromFieldOfView(config_.render_width, config_.render_height, config_.render_fov);
    std::string why;
    if (!tf_buffer_.canTransform(config_.particles_frame, config_.render_frame, ros::Time(0),
                                 ros::Duration(config_.tf_timeout), &why)) {
      throw Error("no tf from '" + config_.particles_frame + "' to ~render_frame '" + config_.render_frame +
                  "': " + why);
    }
    const Eigen::Isometry3d world_from_camera = tf2::transformToEigen(
        tf_buffer_.lookupTransform(config_.particles_frame, config_.render_frame, ros::Time(0)));
    const ros::WallTime start = ros::WallTime::now();
    const cv::Mat rgba = [&] {
      const demnerf::mechanics::BlasCallsInFlight blas_calls;  // the NeRF's matmuls, beside a solve
      return view_.render(job.result, *camera, world_from_camera);  // RGBA float
    }();
    const double seconds = (ros::WallTime::now() - start).toSec();
    std_msgs::Header header;
    header.stamp = job.stamp;
    header.frame_id = config_.render_frame;
    rendered_publisher_.publish(toImageMessage(rgba, header));
    std::ostringstream text;
    text.precision(3);
    text << camera->width << "x" << camera->height << " in " << seconds << " s";
    std::lock_guard<std::mutex> lock(mutex_);
    ++renders_;
    last_render_ = text.str();
  } catch (const std::exception& error) {
    // Bad model files, tf errors and torch errors alike: report, keep the node and the last image.
    reportError("render", std::string("~rendered not updated: ") + error.what());
  } catch (...) {
    reportError("render", "~rendered not updated: unknown exception");
  }
}

}  // namespace dem_nerf
