#include "demnerf/core/metrics.hpp"

#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>

#include "demnerf/core/error.hpp"

namespace demnerf::core {
namespace {

void requireComparable(const cv::Mat& a, const cv::Mat& b, const char* metric) {
  if (a.empty() || a.size() != b.size() || a.type() != b.type() || a.depth() != CV_32F) {
    throw Error(std::string(metric) + ": images must be non-empty float images of equal size and channels");
  }
}

}  // namespace

double psnr(const cv::Mat& a, const cv::Mat& b) {
  requireComparable(a, b, "psnr");
  cv::Mat difference;
  cv::subtract(a, b, difference);
  const cv::Scalar squared = cv::sum(difference.mul(difference));
  double total = 0.0;
  for (int c = 0; c < a.channels(); ++c) total += squared[c];
  const double mse = total / (static_cast<double>(a.total()) * a.channels());
  if (mse <= 0.0) return std::numeric_limits<double>::infinity();
  return -10.0 * std::log10(mse);
}

double ssim(const cv::Mat& a, const cv::Mat& b) {
  requireComparable(a, b, "ssim");
  constexpr double kC1 = 0.01 * 0.01, kC2 = 0.03 * 0.03;
  const cv::Size window(11, 11);
  constexpr double kSigma = 1.5;
  cv::Mat mu_a, mu_b, aa, bb, ab;
  cv::GaussianBlur(a, mu_a, window, kSigma);
  cv::GaussianBlur(b, mu_b, window, kSigma);
  cv::GaussianBlur(a.mul(a), aa, window, kSigma);
  cv::GaussianBlur(b.mul(b), bb, window, kSigma);
  cv::GaussianBlur(a.mul(b), ab, window, kSigma);
  const cv::Mat mu_aa = mu_a.mul(mu_a), mu_bb = mu_b.mul(mu_b), mu_ab = mu_a.mul(mu_b);
  const cv::Mat sigma_aa = aa - mu_aa, sigma_bb = bb - mu_bb, sigma_ab = ab - mu_ab;
  // Scalar::all: a plain double would be added to the first channel only.
  const cv::Scalar c1 = cv::Scalar::all(kC1), c2 = cv::Scalar::all(kC2);
  cv::Mat numerator = (2 * mu_ab + c1).mul(2 * sigma_ab + c2);
  cv::Mat denominator = (mu_aa + mu_bb + c1).mul(sigma_aa + sigma_bb + c2);
  cv::Mat map;
  cv::divide(numerator, denominator, map);
  const cv::Scalar mean = cv::mean(map);
  double total = 0.0;
  for (int c = 0; c < a.channels(); ++c) total += mean[c];
  return total / a.channels();
}

cv::Mat compositeOver(const cv::Mat& rgba, const cv::Vec3f& background) {
  if (rgba.empty() || rgba.type() != CV_32FC4) throw Error("compositeOver: expects a CV_32FC4 image");
  cv::Mat rgb(rgba.size(), CV_32FC3);
  rgba.forEach<cv::Vec4f>([&](const cv::Vec4f& pixel, const int* position) {
    const float alpha = pixel[3];
    rgb.at<cv::Vec3f>(position[0], position[1]) = cv::Vec3f(
        pixel[0] * alpha + background[0] * (1 - alpha), pixel[1] * alpha + background[1] * (1 - alpha),
        pixel[2] * alpha + background[2] * (1 - alpha));
  });
  return rgb;
}

}  // namespace demnerf::core
