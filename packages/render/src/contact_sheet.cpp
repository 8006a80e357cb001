#include "demnerf/render/contact_sheet.hpp"

#include <string>

#include "demnerf/core/error.hpp"

namespace demnerf::render {

cv::Mat makeContactSheet(const std::vector<cv::Mat>& images, int columns, const cv::Vec3f& background, int gap) {
  if (images.empty()) throw core::Error("contact sheet: no images given");
  if (columns < 1) throw core::Error("contact sheet: columns must be positive, got " + std::to_string(columns));
  const cv::Size size = images.front().size();
  const int rows = (static_cast<int>(images.size()) + columns - 1) / columns;
  // The gaps show a darker shade of the background so the tiles' edges are visible.
  cv::Mat sheet(rows * (size.height + gap) + gap, columns * (size.width + gap) + gap, CV_32FC3,
                cv::Scalar(0.6 * background[0], 0.6 * background[1], 0.6 * background[2]));
  for (std::size_t i = 0; i < images.size(); ++i) {
    const cv::Mat& image = images[i];
    if (image.type() != CV_32FC4 || image.size() != size) {
      throw core::Error("contact sheet: image " + std::to_string(i) + " is not a CV_32FC4 image of the first's size");
    }
    const int r = static_cast<int>(i) / columns, c = static_cast<int>(i) % columns;
    cv::Mat tile = sheet(cv::Rect(gap + c * (size.width + gap), gap + r * (size.height + gap), size.width, size.height));
    for (int y = 0; y < size.height; ++y) {
      const auto* in = image.ptr<cv::Vec4f>(y);
      auto* out = tile.ptr<cv::Vec3f>(y);
      for (int x = 0; x < size.width; ++x) {
        const float a = in[x][3];
        for (int k = 0; k < 3; ++k) out[x][k] = a * in[x][k] + (1.0f - a) * background[k];
      }
    }
  }
  return sheet;
}

}  // namespace demnerf::render
