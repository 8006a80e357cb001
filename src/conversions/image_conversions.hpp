#pragma once
// Images between sensor_msgs/Image and the RGBA float matrices (CV_32FC4, values in [0, 1]) that
// the libraries read and render. The one place that knows ROS image encodings.

#include <sensor_msgs/Image.h>
#include <std_msgs/Header.h>

#include <opencv2/core.hpp>

#include <cstdint>

namespace dem_nerf {

/// An image message as RGBA float; throws demnerf::core::Error for unsupported encodings, a
/// layout that does not match its data (checkImageLayout) or more than max_pixels pixels.
/// has_alpha tells whether the message carried an alpha channel (rgba8, bgra8).
cv::Mat toRgba(const sensor_msgs::Image& image, bool* has_alpha, std::uint64_t max_pixels = 4096ull * 4096ull);

/// An RGBA float image (CV_32FC4, [0, 1]; values outside are clamped by the 8-bit conversion) as
/// an rgba8 message with the given header. Throws demnerf::core::Error for any other matrix type.
sensor_msgs::Image toImageMessage(const cv::Mat& rgba, const std_msgs::Header& header);

}  // namespace dem_nerf
