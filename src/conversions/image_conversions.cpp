#include "conversions/image_conversions.hpp"

#include <cv_bridge/cv_bridge.h>
#include <sensor_msgs/image_encodings.h>

#include <boost/make_shared.hpp>

#include <opencv2/imgproc.hpp>

#include "conversions/image_layout.hpp"
#include "demnerf/core/error.hpp"

namespace dem_nerf {

namespace encodings = sensor_msgs::image_encodings;

cv::Mat toRgba(const sensor_msgs::Image& image, bool* has_alpha, std::uint64_t max_pixels) {
  // Every size checked in 64 bits before cv_bridge, whose own check wraps at 2^32 bytes.
  checkImageLayout(image, max_pixels);
  const std::string& e = image.encoding;
  int conversion = -1;
  if (e == encodings::RGB8) conversion = cv::COLOR_RGB2RGBA;
  else if (e == encodings::BGR8) conversion = cv::COLOR_BGR2RGBA;
  else if (e == encodings::MONO8) conversion = cv::COLOR_GRAY2RGBA;
  else if (e == encodings::BGRA8) conversion = cv::COLOR_BGRA2RGBA;
  *has_alpha = e == encodings::RGBA8 || e == encodings::BGRA8;
  cv_bridge::CvImageConstPtr shared;
  try {
    shared = cv_bridge::toCvShare(boost::make_shared<sensor_msgs::Image>(image), e);
  } catch (const std::exception& error) {  // cv_bridge::Exception, cv::Exception
    throw demnerf::core::Error(std::string("image could not be read: ") + error.what());
  }
  try {
    cv::Mat rgba8;
    if (conversion >= 0) cv::cvtColor(shared->image, rgba8, conversion);
    else rgba8 = shared->image;
    cv::Mat rgba;
    rgba8.convertTo(rgba, CV_32FC4, 1.0 / 255.0);
    return rgba;
  } catch (const cv::Exception& error) {
    throw demnerf::core::Error(std::string("image could not be converted: ") + error.what());
  }
}

sensor_msgs::Image toImageMessage(const cv::Mat& rgba, const std_msgs::Header& header) {
  if (rgba.type() != CV_32FC4)
    throw demnerf::core::Error("toImageMessage expects an RGBA float image (CV_32FC4), got OpenCV type " +
                               std::to_string(rgba.type()));
  cv::Mat bytes;
  rgba.convertTo(bytes, CV_8UC4, 255.0);  // saturating: out-of-range values clamp to 0 or 255
  return *cv_bridge::CvImage(header, encodings::RGBA8, bytes).toImageMsg();
}

}  // namespace dem_nerf
