#pragma once
// Image quality metrics used to judge reconstructions and renders.

#include <opencv2/core.hpp>

namespace demnerf::core {

/// Peak signal-to-noise ratio in dB of two images with values in [0, 1] (same size and
/// channels, float). Identical images give +infinity.
double psnr(const cv::Mat& a, const cv::Mat& b);

/// Mean structural similarity (Gaussian window 11, sigma 1.5, K1 0.01, K2 0.03) over all
/// channels, for images in [0, 1].
double ssim(const cv::Mat& a, const cv::Mat& b);

/// Composites RGBA over a constant background colour; returns CV_32FC3.
cv::Mat compositeOver(const cv::Mat& rgba, const cv::Vec3f& background);

}  // namespace demnerf::core
