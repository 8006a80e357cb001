// Reading and writing images as float RGBA, whatever the file's depth and channel count.

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "demnerf/core/dataset.hpp"
#include "demnerf/core/error.hpp"

namespace demnerf::core {

cv::Mat readImageRgba(const std::string& path, bool* has_alpha) {
  const cv::Mat raw = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (raw.empty()) throw Error("cannot read image '" + path + "' (missing or not an image)");
  double scale = 1.0;
  switch (raw.depth()) {
    case CV_8U: scale = 1.0 / 255.0; break;
    case CV_16U: scale = 1.0 / 65535.0; break;
    case CV_32F: scale = 1.0; break;
    default: throw Error("image '" + path + "' has an unsupported pixel depth (use 8 or 16 bit)");
  }
  cv::Mat rgba;
  switch (raw.channels()) {
    case 1: cv::cvtColor(raw, rgba, cv::COLOR_GRAY2RGBA); break;
    case 3: cv::cvtColor(raw, rgba, cv::COLOR_BGR2RGBA); break;
    case 4: cv::cvtColor(raw, rgba, cv::COLOR_BGRA2RGBA); break;
    default: throw Error("image '" + path + "' has " + std::to_string(raw.channels()) + " channels");
  }
  if (has_alpha != nullptr) *has_alpha = raw.channels() == 4;
  cv::Mat result;
  rgba.convertTo(result, CV_32FC4, scale);
  return result;
}

void writeImagePng(const std::string& path, const cv::Mat& image) {
  if (image.empty() || image.depth() != CV_32F || (image.channels() != 3 && image.channels() != 4)) {
    throw Error("writeImagePng: expects a non-empty float RGB or RGBA image for '" + path + "'");
  }
  cv::Mat bgr;
  cv::cvtColor(image, bgr, image.channels() == 4 ? cv::COLOR_RGBA2BGRA : cv::COLOR_RGB2BGR);
  cv::Mat bytes;
  bgr.convertTo(bytes, image.channels() == 4 ? CV_8UC4 : CV_8UC3, 255.0);
  if (!cv::imwrite(path, bytes)) throw Error("cannot write image '" + path + "' (folder missing or disk full?)");
}

}  // namespace demnerf::core
