#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>

#include "demnerf/core/error.hpp"
#include "demnerf/core/metrics.hpp"

using namespace demnerf::core;

TEST(Metrics, PsnrOfAKnownError) {
  cv::Mat a(16, 16, CV_32FC3, cv::Scalar(0.5, 0.5, 0.5));
  cv::Mat b = a + cv::Scalar::all(0.1);  // MSE 0.01 -> 20 dB
  EXPECT_NEAR(psnr(a, b), 20.0, 1e-4);
  EXPECT_TRUE(std::isinf(psnr(a, a)));
  EXPECT_THROW(psnr(a, cv::Mat(8, 8, CV_32FC3)), Error);
}

TEST(Metrics, SsimIsOneForEqualImagesAndDropsWithNoise) {
  cv::Mat a(64, 64, CV_32FC3);
  cv::randu(a, 0.0, 1.0);
  cv::GaussianBlur(a, a, cv::Size(5, 5), 1.0);
  EXPECT_NEAR(ssim(a, a), 1.0, 1e-6);
  cv::Mat noise(64, 64, CV_32FC3);
  cv::randn(noise, 0.0, 0.1);
  const double noisy = ssim(a, a + noise);
  EXPECT_LT(noisy, 0.9);
  EXPECT_GT(noisy, 0.0);
}

TEST(Metrics, CompositeOverUsesStraightAlpha) {
  cv::Mat rgba(1, 1, CV_32FC4, cv::Scalar(1.0, 0.0, 0.0, 0.25));
  const cv::Mat rgb = compositeOver(rgba, cv::Vec3f(0, 0, 1));
  const cv::Vec3f pixel = rgb.at<cv::Vec3f>(0, 0);
  EXPECT_FLOAT_EQ(pixel[0], 0.25f);
  EXPECT_FLOAT_EQ(pixel[2], 0.75f);
}
