#include "conversions/image_layout.hpp"

#include <sensor_msgs/image_encodings.h>

#include "demnerf/core/error.hpp"

namespace dem_nerf {

std::uint32_t bytesPerPixel(const std::string& e) {
  namespace encodings = sensor_msgs::image_encodings;
  if (e == encodings::MONO8) return 1;
  if (e == encodings::RGB8 || e == encodings::BGR8) return 3;
  if (e == encodings::RGBA8 || e == encodings::BGRA8) return 4;
  return 0;
}

void checkImageLayout(const sensor_msgs::Image& image, std::uint64_t max_pixels) {
  using demnerf::core::Error;
  const std::uint64_t bytes = bytesPerPixel(image.encoding);
  if (bytes == 0)
    throw Error("image encoding '" + image.encoding + "' is not supported (use rgb8, bgr8, rgba8, bgra8 or mono8)");
  const std::uint64_t width = image.width, height = image.height, step = image.step;
  const std::string size = std::to_string(width) + "x" + std::to_string(height);
  if (width == 0 || height == 0) throw Error("image is empty (" + size + ")");
  if (width * height > max_pixels)
    throw Error("image " + size + " has more than the " + std::to_string(max_pixels) + " pixels accepted");
  if (step < width * bytes)
    throw Error("image step " + std::to_string(step) + " is shorter than a row of " + std::to_string(width) + " " +
                image.encoding + " pixels (" + std::to_string(width * bytes) + " bytes)");
  if (static_cast<std::uint64_t>(image.data.size()) != step * height)
    throw Error("image data holds " + std::to_string(image.data.size()) + " bytes, but step x height = " +
                std::to_string(step * height) + " (" + size + ")");
}

}  // namespace dem_nerf
