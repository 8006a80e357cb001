// NeRF training benchmark: trains on a dataset for a wall-clock budget and records the
// held-out PSNR against training seconds (evaluation time excluded), throughput and where
// the time goes.
//   nerf_train --data DIR [--seconds 60] [--downscale 1] [--config nerf.yaml]
//              [--eval-every 10] [--csv curve.csv] [--plot curve.png] [--model out.nerf]
//              [--iterations N]   (a fixed number of steps instead of seconds: compares
//                                  configurations on a loaded machine)

#include <chrono>
#include <cstdio>
#include <fstream>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>

#include "demnerf/core/dataset.hpp"
#include "demnerf/nerf/evaluate.hpp"
#include "demnerf/nerf/model_io.hpp"
#include "demnerf/nerf/trainer.hpp"

using namespace demnerf;

namespace {

struct Row {
  double seconds, train_psnr, test_psnr, rays_per_second, samples_per_second, samples_per_ray;
  long long iteration;
};

void plot(const std::vector<Row>& rows, const std::string& path, const std::string& title) {
  const int w = 640, h = 400, m = 50;
  cv::Mat img(h, w, CV_8UC3, cv::Scalar(255, 255, 255));
  double tmax = 1, pmin = 10, pmax = 40;
  for (const Row& r : rows) tmax = std::max(tmax, r.seconds);
  auto px = [&](double t, double p) {
    return cv::Point(m + static_cast<int>((w - 2 * m) * t / tmax),
                     h - m - static_cast<int>((h - 2 * m) * (std::clamp(p, pmin, pmax) - pmin) / (pmax - pmin)));
  };
  cv::rectangle(img, px(0, pmin), px(tmax, pmax), cv::Scalar(0, 0, 0));
  for (double p = pmin; p <= pmax; p += 5) {
    cv::line(img, px(0, p), px(tmax, p), cv::Scalar(220, 220, 220));
    cv::putText(img, std::to_string(static_cast<int>(p)), px(0, p) + cv::Point(-30, 4), cv::FONT_HERSHEY_SIMPLEX, 0.4,
                cv::Scalar(0, 0, 0));
  }
  for (std::size_t i = 1; i < rows.size(); ++i) {
    cv::line(img, px(rows[i - 1].seconds, rows[i - 1].test_psnr), px(rows[i].seconds, rows[i].test_psnr),
             cv::Scalar(200, 60, 0), 2);
  }
  cv::putText(img, title + ": held-out PSNR (dB) vs training seconds (0 .. " + std::to_string(static_cast<int>(tmax)) +
                       ")", cv::Point(m, 25), cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0));
  cv::imwrite(path, img);
}

}  // namespace

int main(int argc, char** argv) {
  std::map<std::string, std::string> args;
  for (int i = 1; i + 1 < argc; i += 2) args[std::string(argv[i]).substr(2)] = argv[i + 1];
  auto get = [&](const std::string& k, const std::string& d) { return args.count(k) ? args[k] : d; };
  if (!args.count("data")) {
    std::fprintf(stderr, "usage: nerf_train --data DIR [--seconds 60] [--downscale 1] [--config nerf.yaml] "
                         "[--eval-every 10] [--csv curve.csv] [--plot curve.png] [--model out.nerf]\n");
    return 2;
  }
  try {
    const double seconds = std::stod(get("seconds", "60"));
    const double eval_every = std::stod(get("eval-every", "10"));
    core::DatasetOptions options;
    options.downscale = std::stod(get("downscale", "1"));
    const core::Dataset dataset = core::loadDataset(args["data"], options);
    nerf::NerfConfig config = args.count("config") ? nerf::loadNerfConfig(args["config"]) : nerf::NerfConfig{};
    nerf::Trainer trainer(config, nerf::datasetBox(dataset), dataset.aabb_scale);
    trainer.addFrames(dataset.train);
    std::fprintf(stderr, "nerf_train: %zu train / %zu test views, %dx%d, box %.3g x %.3g x %.3g, aabb_scale %.3g\n",
                 dataset.train.size(), dataset.test.size(), dataset.train[0].camera.width,
                 dataset.train[0].camera.height, dataset.bounds.sizes().x(), dataset.bounds.sizes().y(),
                 dataset.bounds.sizes().z(), dataset.aabb_scale);
    std::vector<Row> rows;
    double trained = 0;
    nerf::TrainProgress last;
    const long long iterations = std::stoll(get("iterations", "0"));
    if (iterations > 0) {
      last = trainer.train({0, iterations}, {}, true, 5.0);
      trained = last.seconds;
    }
    while (iterations == 0 && trained < seconds - 1e-6) {
      const double slice = std::min(eval_every, seconds - trained);
      // The schedule decays over the whole run, not the slice.
      last = trainer.train({slice, 0}, {}, true, 5.0);
      trained += last.seconds;
      trainer.setBudget({seconds, 0});
      const nerf::Evaluation e = nerf::evaluate(trainer.model(), dataset.test, false);
      rows.push_back({trained, last.psnr, e.psnr, last.rays_per_second, last.samples_per_second, last.samples_per_ray,
                      static_cast<long long>(last.iteration)});
      std::fprintf(stderr, "nerf_train: %.1f s  it %lld  train %.2f dB  test %.2f dB  render %.3f s/view\n", trained,
                   rows.back().iteration, last.psnr, e.psnr, e.seconds_per_view);
    }
    const nerf::Evaluation final_eval = nerf::evaluate(trainer.model(), dataset.test, true);
    const nerf::StepTimes& t = trainer.times();
    std::printf("trained_seconds %.2f\niterations %lld\ntest_psnr %.3f\ntest_ssim %.4f\nrender_seconds_per_view %.3f\n"
                "render_samples_per_pixel %.1f\noccupied_fraction %.4f\n",
                trained, static_cast<long long>(trainer.iteration()), final_eval.psnr, final_eval.ssim,
                final_eval.seconds_per_view, final_eval.samples_per_pixel, last.occupied_fraction);
    std::printf("rays_per_second %.0f\nsamples_per_second %.0f\nsamples_per_ray %.1f\n", last.rays_per_second,
                last.samples_per_second, last.samples_per_ray);
    std::printf("time_march %.2f\ntime_forward %.2f\ntime_backward_mlp %.2f\ntime_backward_table %.2f\ntime_optimizer %.2f\n"
                "time_occupancy %.2f\ntime_encode_forward_part %.2f\n",
                t.march, t.march_forward, t.backward_mlp, t.backward_table, t.optimizer, t.occupancy, t.encode_forward);
    if (args.count("csv")) {
      std::ofstream csv(args["csv"]);
      csv << "seconds,iteration,train_psnr,test_psnr,rays_per_second,samples_per_second,samples_per_ray\n";
      for (const Row& r : rows) {
        csv << r.seconds << "," << r.iteration << "," << r.train_psnr << "," << r.test_psnr << "," << r.rays_per_second
            << "," << r.samples_per_second << "," << r.samples_per_ray << "\n";
      }
    }
    if (args.count("plot")) plot(rows, args["plot"], args["data"]);
    if (args.count("model")) nerf::saveModel(trainer.model(), args["model"]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "nerf_train: %s\n", e.what());
    return 1;
  }
  return 0;
}
