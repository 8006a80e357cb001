#include "conversions/dataset_messages.hpp"

#include <cv_bridge/cv_bridge.h>
#include <sensor_msgs/image_encodings.h>
#include <tf2_eigen/tf2_eigen.h>

#include <opencv2/imgproc.hpp>

#include "conversions/camera_info_conversions.hpp"

namespace dem_nerf {

std::string opticalFrameName(const FrameNaming& naming, std::size_t index) {
  return naming.frame_prefix + std::to_string(index) + "_optical";
}

FrameMessages toMessages(const demnerf::core::Frame& frame, std::size_t index, const ros::Time& stamp,
                         const FrameNaming& naming) {
  FrameMessages messages;
  std_msgs::Header header;
  header.stamp = stamp;
  header.frame_id = opticalFrameName(naming, index);

  cv::Mat bytes;
  if (frame.has_alpha) {
    frame.rgba.convertTo(bytes, CV_8UC4, 255.0);
    messages.image = *cv_bridge::CvImage(header, sensor_msgs::image_encodings::RGBA8, bytes).toImageMsg();
  } else {
    cv::Mat rgb;
    cv::cvtColor(frame.rgba, rgb, cv::COLOR_RGBA2RGB);
    rgb.convertTo(bytes, CV_8UC3, 255.0);
    messages.image = *cv_bridge::CvImage(header, sensor_msgs::image_encodings::RGB8, bytes).toImageMsg();
  }
  messages.camera_info = toCameraInfo(frame.camera, header);
  messages.pose = tf2::eigenToTransform(frame.world_from_camera);
  messages.pose.header.stamp = stamp;
  messages.pose.header.frame_id = naming.world_frame;
  messages.pose.child_frame_id = header.frame_id;
  return messages;
}

}  // namespace dem_nerf
