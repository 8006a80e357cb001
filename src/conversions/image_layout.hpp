#pragma once
// A sensor_msgs/Image checked completely before cv_bridge sees it. cv_bridge compares
// height * step with data.size() in 32 bits, so 65537 x 65536 bytes wraps to 65536 and the image
// is read past its buffer (issue 14); here every size is computed in 64 bits.

#include <sensor_msgs/Image.h>

#include <cstdint>

namespace dem_nerf {

/// Throws demnerf::core::Error naming the problem: an encoding other than rgb8, bgr8, rgba8,
/// bgra8, mono8; a zero width or height; more than max_pixels pixels; a step shorter than a row;
/// data.size() other than step x height.
void checkImageLayout(const sensor_msgs::Image& image, std::uint64_t max_pixels);

/// Bytes per pixel of the 8-bit encodings the nodes read (0 for any other encoding).
std::uint32_t bytesPerPixel(const std::string& encoding);

}  // namespace dem_nerf
