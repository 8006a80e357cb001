// Deformed rendering benchmark: a trained NeRF of the rest object, a displacement result, and
// ground-truth renders of the deformed object (`demnerf synth --result R.ply`) on the same test
// cameras. Reports PSNR of the zero-displacement render against the undeformed renderer, PSNR of
// the deformed render against ground truth (with and without rotating view directions), and
// seconds per view (median of `--repeats`), and writes a side-by-side picture.
//
//   render_deformed_bench --particles P.ply --twist-degrees 20 --write-result R.ply
//       (writes a twist result: rotation about +z through x = y = 0 growing linearly with z)
//   render_deformed_bench --model M --data REST_DIR --result R.ply --truth DEFORMED_DIR
//       [--threads 2] [--repeats 3] [--picture docs/deformed_render.png]

#include <ATen/Parallel.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>

#include "demnerf/core/dataset.hpp"
#include "demnerf/core/error.hpp"
#include "demnerf/core/metrics.hpp"
#include "demnerf/core/ply.hpp"
#include "demnerf/nerf/model_io.hpp"
#include "demnerf/nerf/renderer.hpp"
#include "demnerf/render/deformed_renderer.hpp"

using namespace demnerf;

namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

cv::Mat overBackground(const cv::Mat& rgba, const Eigen::Vector3f& bg) {
  cv::Mat rgb(rgba.size(), CV_32FC3);
  for (int y = 0; y < rgba.rows; ++y)
    for (int x = 0; x < rgba.cols; ++x) {
      const cv::Vec4f p = rgba.at<cv::Vec4f>(y, x);
      rgb.at<cv::Vec3f>(y, x) = cv::Vec3f(p[0] * p[3] + bg[0] * (1 - p[3]), p[1] * p[3] + bg[1] * (1 - p[3]),
                                          p[2] * p[3] + bg[2] * (1 - p[3]));
    }
  return rgb;
}

cv::Mat toBgr8(const cv::Mat& rgb) {
  cv::Mat bgr, out;
  cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
  bgr.convertTo(out, CV_8UC3, 255.0);
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  std::map<std::string, std::string> args;
  for (int i = 1; i + 1 < argc; i += 2) args[std::string(argv[i]).substr(2)] = argv[i + 1];
  auto get = [&](const std::string& k, const std::string& d) { return args.count(k) ? args[k] : d; };
  try {
    if (args.count("write-result")) {
      const core::ParticleCloud cloud = core::readParticles(get("particles", ""));
      const double degrees = std::stod(get("twist-degrees", "20"));
      const double height = std::stod(get("height", "0.30"));
      core::ResultField result;
      for (const auto& p : cloud.positions) {
        const double angle = degrees * M_PI / 180.0 * p.z() / height;
        const double c = std::cos(angle), s = std::sin(angle);
        result.positions.push_back(p);
        result.displacements.emplace_back(c * p.x() - s * p.y() - p.x(), s * p.x() + c * p.y() - p.y(), 0.0);
        result.von_mises.push_back(0.0);
      }
      core::writeResult(args["write-result"], result);
      std::printf("wrote %s: %zu particles, twist %.1f deg at z = %.3f m\n", args["write-result"].c_str(),
                  result.size(), degrees, height);
      return 0;
    }
    const int threads = std::stoi(get("threads", "2"));
    const int repeats = std::stoi(get("repeats", "3"));
    if (threads > 0) at::set_num_threads(threads);
    const nerf::NerfModel model = nerf::loadModel(get("model", ""));
    const core::Dataset rest_data = core::loadDataset(get("data", ""));
    const core::Dataset truth_data = core::loadDataset(get("truth", ""));
    const core::ResultField result = core::readResult(get("result", ""));
    const auto& bgd = model.config().background;
    const Eigen::Vector3f bg(static_cast<float>(bgd[0]), static_cast<float>(bgd[1]), static_cast<float>(bgd[2]));

    core::ResultField zero = result;
    for (auto& u : zero.displacements) u.setZero();
    auto t0 = std::chrono::steady_clock::now();
    render::DeformedRenderConfig with_rotation;
    const render::DeformedScene twisted(model, result, with_rotation);
    const double build_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    render::DeformedRenderConfig no_rotation;
    no_rotation.rotate_directions = false;
    const render::DeformedScene twisted_plain(model, result, no_rotation);
    const render::DeformedScene identity(model, zero, with_rotation);
    std::printf("embedding: %zu particles, %zu tets, spacing %.4f m, min J %.3f, build %.3f s, grid %d^3 (%.1f%% occupied)\n",
                twisted.embedding().particleCount(), twisted.embedding().tetCount(), twisted.embedding().spacing(),
                twisted.embedding().minVolumeRatio(), build_seconds, twisted.grid().resolution(),
                100.0 * twisted.grid().occupiedFraction());

    const auto& rest_frames = rest_data.split("test");
    const auto& truth_frames = truth_data.split("test");
    if (rest_frames.size() != truth_frames.size()) throw core::Error("rest and truth test splits differ in size");
    std::vector<double> p_identity, p_twist, p_twist_plain, p_rest_vs_truth, p_nerf_rest, seconds, seconds_rest;
    for (std::size_t v = 0; v < rest_frames.size(); ++v) {
      const auto& f = rest_frames[v];
      const auto& g = truth_frames[v];
      if ((f.world_from_camera.matrix() - g.world_from_camera.matrix()).norm() > 1e-6) {
        throw core::Error("test view " + std::to_string(v) + ": rest and truth cameras differ");
      }
      std::vector<double> times, times_rest;
      nerf::RenderedImage deformed, undeformed;
      for (int r = 0; r < repeats; ++r) {
        deformed = render::renderDeformed(twisted, f.camera, f.world_from_camera, bg);
        times.push_back(deformed.seconds);
        undeformed = nerf::renderImage(model, f.camera, f.world_from_camera, bg);
        times_rest.push_back(undeformed.seconds);
      }
      seconds.push_back(median(times));
      seconds_rest.push_back(median(times_rest));
      const auto plain = render::renderDeformed(twisted_plain, f.camera, f.world_from_camera, bg);
      const auto ident = render::renderDeformed(identity, f.camera, f.world_from_camera, bg);
      const cv::Mat truth = overBackground(g.rgba, bg), rest_truth = overBackground(f.rgba, bg);
      p_identity.push_back(core::psnr(ident.color, undeformed.color));
      p_twist.push_back(core::psnr(deformed.color, truth));
      p_twist_plain.push_back(core::psnr(plain.color, truth));
      p_rest_vs_truth.push_back(core::psnr(undeformed.color, truth));
      p_nerf_rest.push_back(core::psnr(undeformed.color, rest_truth));
      std::printf("view %zu: identity %.2f dB | twist %.2f dB (no rotation %.2f) | undeformed vs twisted truth %.2f | "
                  "NeRF rest %.2f dB | %.3f s deformed, %.3f s undeformed\n",
                  v, p_identity.back(), p_twist.back(), p_twist_plain.back(), p_rest_vs_truth.back(),
                  p_nerf_rest.back(), seconds.back(), seconds_rest.back());
      if (v == 0 && args.count("picture")) {
        cv::Mat side;
        cv::Mat gap(truth.rows, 4, CV_32FC3, cv::Scalar(0, 0, 0));
        cv::hconcat(std::vector<cv::Mat>{undeformed.color, gap, deformed.color, gap, truth}, side);
        cv::Mat out = toBgr8(side);
        cv::Mat banner(22, out.cols, CV_8UC3, cv::Scalar(255, 255, 255));
        const int w = truth.cols + 4;
        cv::putText(banner, "NeRF, rest", cv::Point(4, 15), cv::FONT_HERSHEY_SIMPLEX, 0.42, cv::Scalar(0, 0, 0));
        cv::putText(banner, "NeRF, deformed", cv::Point(w + 4, 15), cv::FONT_HERSHEY_SIMPLEX, 0.42, cv::Scalar(0, 0, 0));
        cv::putText(banner, "ground truth, deformed", cv::Point(2 * w + 4, 15), cv::FONT_HERSHEY_SIMPLEX, 0.42,
                    cv::Scalar(0, 0, 0));
        cv::vconcat(banner, out, out);
        cv::imwrite(args["picture"], out);
      }
    }
    auto minOf = [](const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); };
    std::printf("SUMMARY threads %d views %zu | identity PSNR median %.2f min %.2f dB | twist PSNR median %.2f min %.2f "
                "dB (no rotation median %.2f) | undeformed vs twisted truth %.2f dB | NeRF rest PSNR %.2f dB | "
                "deformed %.3f s/view (median of %d), undeformed %.3f s/view\n",
                threads, seconds.size(), median(p_identity), minOf(p_identity), median(p_twist), minOf(p_twist),
                median(p_twist_plain), median(p_rest_vs_truth), median(p_nerf_rest), median(seconds), repeats,
                median(seconds_rest));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "render_deformed_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
