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
#include <memory>
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

using Arguments = std::map<std::string, std::string>;

std::string get(const Arguments& args, const std::string& key, const std::string& fallback) {
  const auto it = args.find(key);
  return it != args.end() ? it->second : fallback;
}

/// --write-result: a twist about +z through x = y = 0 growing linearly with z, at the particles.
void writeTwistResult(const Arguments& args) {
  const core::ParticleCloud cloud = core::readParticles(get(args, "particles", ""));
  const double degrees = std::stod(get(args, "twist-degrees", "20"));
  const double height = std::stod(get(args, "height", "0.30"));
  core::ResultField result;
  for (const auto& p : cloud.positions) {
    const double angle = degrees * M_PI / 180.0 * p.z() / height;
    const double c = std::cos(angle), s = std::sin(angle);
    result.positions.push_back(p);
    result.displacements.emplace_back(c * p.x() - s * p.y() - p.x(), s * p.x() + c * p.y() - p.y(), 0.0);
    result.von_mises.push_back(0.0);
  }
  const std::string path = args.at("write-result");
  core::writeResult(path, result);
  std::printf("wrote %s: %zu particles, twist %.1f deg at z = %.3f m\n", path.c_str(), result.size(), degrees, height);
}

/// The three renders of the first view side by side under a banner naming them.
void writePicture(const std::string& path, const cv::Mat& rest, const cv::Mat& deformed, const cv::Mat& truth) {
  cv::Mat side;
  cv::Mat gap(truth.rows, 4, CV_32FC3, cv::Scalar(0, 0, 0));
  cv::hconcat(std::vector<cv::Mat>{rest, gap, deformed, gap, truth}, side);
  cv::Mat out = toBgr8(side);
  cv::Mat banner(22, out.cols, CV_8UC3, cv::Scalar(255, 255, 255));
  const int w = truth.cols + 4;
  cv::putText(banner, "NeRF, rest", cv::Point(4, 15), cv::FONT_HERSHEY_SIMPLEX, 0.42, cv::Scalar(0, 0, 0));
  cv::putText(banner, "NeRF, deformed", cv::Point(w + 4, 15), cv::FONT_HERSHEY_SIMPLEX, 0.42, cv::Scalar(0, 0, 0));
  cv::putText(banner, "ground truth, deformed", cv::Point(2 * w + 4, 15), cv::FONT_HERSHEY_SIMPLEX, 0.42,
              cv::Scalar(0, 0, 0));
  cv::vconcat(banner, out, out);
  cv::imwrite(path, out);
}

render::DeformedRenderConfig directions(bool rotate) {
  render::DeformedRenderConfig config;
  config.rotate_directions = rotate;
  return config;
}

core::ResultField zeroDisplacement(core::ResultField result) {
  for (auto& u : result.displacements) u.setZero();
  return result;
}

/// The deformed scenes of one result: twisted (view directions rotated), twisted without the
/// rotation, and the identity (zero displacement, to compare with the undeformed renderer).
/// Members are built in declaration order, so build_seconds times the first scene alone.
struct Scenes {
  Scenes(const nerf::NerfModel& model, const core::ResultField& result)
      : twisted(model, result, directions(true)),
        build_seconds(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()),
        twisted_plain(model, result, directions(false)),
        zero(zeroDisplacement(result)),
        identity(model, zero, directions(true)) {}

  std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
  render::DeformedScene twisted;
  double build_seconds;
  render::DeformedScene twisted_plain;
  core::ResultField zero;
  render::DeformedScene identity;
};

/// Per test view: PSNRs and seconds per view (median of the repeats).
struct Measures {
  std::vector<double> identity, twist, twist_plain, rest_vs_truth, nerf_rest, seconds, seconds_rest;
};

void measureView(const nerf::NerfModel& model, const Scenes& scenes, const core::Frame& f, const core::Frame& g,
                 const Eigen::Vector3f& bg, int repeats, const std::string& picture, Measures& m) {
  std::vector<double> times, times_rest;
  nerf::RenderedImage deformed, undeformed;
  for (int r = 0; r < repeats; ++r) {
    deformed = render::renderDeformed(scenes.twisted, f.camera, f.world_from_camera, bg);
    times.push_back(deformed.seconds);
    undeformed = nerf::renderImage(model, f.camera, f.world_from_camera, bg);
    times_rest.push_back(undeformed.seconds);
  }
  m.seconds.push_back(median(times));
  m.seconds_rest.push_back(median(times_rest));
  const auto plain = render::renderDeformed(scenes.twisted_plain, f.camera, f.world_from_camera, bg);
  const auto ident = render::renderDeformed(scenes.identity, f.camera, f.world_from_camera, bg);
  const cv::Mat truth = overBackground(g.rgba, bg), rest_truth = overBackground(f.rgba, bg);
  m.identity.push_back(core::psnr(ident.color, undeformed.color));
  m.twist.push_back(core::psnr(deformed.color, truth));
  m.twist_plain.push_back(core::psnr(plain.color, truth));
  m.rest_vs_truth.push_back(core::psnr(undeformed.color, truth));
  m.nerf_rest.push_back(core::psnr(undeformed.color, rest_truth));
  if (!picture.empty()) writePicture(picture, undeformed.color, deformed.color, truth);
}

void run(const Arguments& args) {
  const int threads = std::stoi(get(args, "threads", "2"));
  const int repeats = std::stoi(get(args, "repeats", "3"));
  if (threads > 0) at::set_num_threads(threads);
  const nerf::NerfModel model = nerf::loadModel(get(args, "model", ""));
  const core::Dataset rest_data = core::loadDataset(get(args, "data", ""));
  const core::Dataset truth_data = core::loadDataset(get(args, "truth", ""));
  const core::ResultField result = core::readResult(get(args, "result", ""));
  const auto& bgd = model.config().background;
  const Eigen::Vector3f bg(static_cast<float>(bgd[0]), static_cast<float>(bgd[1]), static_cast<float>(bgd[2]));
  const auto scenes = std::make_unique<Scenes>(model, result);
  const render::DeformedScene& twisted = scenes->twisted;
  std::printf("embedding: %zu particles, %zu tets, spacing %.4f m, min J %.3f, build %.3f s, grid %d^3 (%.1f%% occupied)\n",
              twisted.embedding().particleCount(), twisted.embedding().tetCount(), twisted.embedding().spacing(),
              twisted.embedding().minVolumeRatio(), scenes->build_seconds, twisted.grid().resolution(),
              100.0 * twisted.grid().occupiedFraction());

  const auto& rest_frames = rest_data.split("test");
  const auto& truth_frames = truth_data.split("test");
  if (rest_frames.size() != truth_frames.size()) throw core::Error("rest and truth test splits differ in size");
  Measures m;
  for (std::size_t v = 0; v < rest_frames.size(); ++v) {
    const auto& f = rest_frames[v];
    const auto& g = truth_frames[v];
    if ((f.world_from_camera.matrix() - g.world_from_camera.matrix()).norm() > 1e-6) {
      throw core::Error("test view " + std::to_string(v) + ": rest and truth cameras differ");
    }
    measureView(model, *scenes, f, g, bg, repeats, v == 0 ? get(args, "picture", "") : "", m);
    std::printf("view %zu: identity %.2f dB | twist %.2f dB (no rotation %.2f) | undeformed vs twisted truth %.2f | "
                "NeRF rest %.2f dB | %.3f s deformed, %.3f s undeformed\n",
                v, m.identity.back(), m.twist.back(), m.twist_plain.back(), m.rest_vs_truth.back(),
                m.nerf_rest.back(), m.seconds.back(), m.seconds_rest.back());
  }
  auto minOf = [](const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); };
  std::printf("SUMMARY threads %d views %zu | identity PSNR median %.2f min %.2f dB | twist PSNR median %.2f min %.2f "
              "dB (no rotation median %.2f) | undeformed vs twisted truth %.2f dB | NeRF rest PSNR %.2f dB | "
              "deformed %.3f s/view (median of %d), undeformed %.3f s/view\n",
              threads, m.seconds.size(), median(m.identity), minOf(m.identity), median(m.twist), minOf(m.twist),
              median(m.twist_plain), median(m.rest_vs_truth), median(m.nerf_rest), median(m.seconds), repeats,
              median(m.seconds_rest));
}

}  // namespace

int main(int argc, char** argv) {
  Arguments args;
  for (int i = 1; i + 1 < argc; i += 2) args[std::string(argv[i]).substr(2)] = argv[i + 1];
  try {
    if (args.count("write-result")) {
      writeTwistResult(args);
    } else {
      run(args);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "render_deformed_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
