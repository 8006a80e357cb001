// NeRF training benchmark: trains on a dataset for a wall-clock budget and records the
// held-out PSNR against training seconds (evaluation time excluded), throughput and where
// the time goes.
//   nerf_train --data DIR [--seconds 60] [--downscale 1] [--config nerf.yaml]
//              [--eval-every 10] [--csv curve.csv] [--plot curve.png] [--model out.nerf]
//              [--iterations N]   (a fixed number of steps instead of seconds: compares
//                                  configurations on a loaded machine)
//              [--cpu-seconds C]  (a budget of this process's CPU seconds instead of wall seconds;
//                                  C = 2 x seconds on an idle 2-core machine)
// The CSV has wall and CPU seconds and the held-out renders' samples per pixel per row.

#include <ATen/Parallel.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <cstdio>
#include <fstream>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <thread>

#include "demnerf/core/dataset.hpp"
#include "demnerf/nerf/evaluate.hpp"
#include "demnerf/nerf/model_io.hpp"
#include "demnerf/nerf/trainer.hpp"

using namespace demnerf;

namespace {

struct Row {
  double seconds, train_psnr, test_psnr, rays_per_second, samples_per_second, samples_per_ray;
  long long iteration;
  double cpu_seconds, render_samples_per_pixel;
};

/// Throughput and smoothed training PSNR over the steps since the last report.
struct Window {
  double mse = -1, seconds = 0;
  std::int64_t rays = 0, samples = 0, marched = 0, steps = 0;
  void add(const nerf::StepResult& r) {
    mse = mse < 0 ? r.mse : 0.9 * mse + 0.1 * r.mse;
    rays += r.rays;
    samples += r.samples;
    marched += r.marched;
    ++steps;
  }
  nerf::TrainProgress progress(nerf::Trainer& trainer, double trained) {
    nerf::TrainProgress p;
    p.iteration = trainer.iteration();
    p.seconds = trained;
    p.psnr = mse > 0 ? -10.0 * std::log10(mse) : 0.0;
    const double window = std::max(1e-9, trained - seconds);
    p.rays_per_second = rays / window;
    p.samples_per_second = samples / window;
    p.samples_per_ray = rays ? static_cast<double>(marched) / rays : 0.0;
    p.occupied_fraction = trainer.model().grid().occupiedFraction();
    seconds = trained;
    return p;
  }
};

/// CPU seconds of this process (all threads): beside wall seconds, a cost that other jobs on
/// the shared machine inflate far less (they take cores away, not cycles from this process).
double cpuSeconds() { return static_cast<double>(std::clock()) / CLOCKS_PER_SEC; }

void plot(const std::vector<Row>& rows, const std::string& path, const std::string& title, bool cpu) {
  auto x = [cpu](const Row& r) { return cpu ? r.cpu_seconds : r.seconds; };
  const int w = 640, h = 400, m = 50;
  cv::Mat img(h, w, CV_8UC3, cv::Scalar(255, 255, 255));
  double tmax = 1, pmin = 10, pmax = 40;
  for (const Row& r : rows) tmax = std::max(tmax, x(r));
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
    cv::line(img, px(x(rows[i - 1]), rows[i - 1].test_psnr), px(x(rows[i]), rows[i].test_psnr),
             cv::Scalar(200, 60, 0), 2);
  }
  cv::putText(img, title + ": held-out PSNR (dB) vs training " + (cpu ? "CPU " : "") + "seconds (0 .. " + std::to_string(static_cast<int>(tmax)) +
                       ")", cv::Point(m, 25), cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0));
  cv::imwrite(path, img);
}

struct Budget {
  long long iterations = 0;
  double seconds = 60, cpu_seconds = 0, eval_every = 10;
};
struct Curve {
  std::vector<Row> rows;
  double trained = 0, cpu_trained = 0;  ///< wall and CPU seconds of training (evaluations excluded)
  nerf::TrainProgress last;
  bool by_cpu = false;
};

/// Trains to the budget, evaluating the held-out views every eval_every (wall or CPU) seconds.
Curve trainCurve(nerf::Trainer& trainer, const core::Dataset& dataset, const Budget& b) {
  // Budgets: --iterations N, or --seconds S of wall time, or --cpu-seconds C of this
  // process's CPU time (C = 2 S on an idle 2-core machine; what a loaded machine inflates least).
  const long long iterations = b.iterations;
  const double cpu_budget = b.cpu_seconds, seconds = b.seconds, eval_every = b.eval_every;
  const bool by_cpu = cpu_budget > 0;
  const double budget = by_cpu ? cpu_budget : seconds;
  Curve curve;
  std::vector<Row>& rows = curve.rows;
  double& trained = curve.trained;
  double& cpu_trained = curve.cpu_trained;
  double next_eval = eval_every;
  Window window;
  nerf::TrainProgress& last = curve.last;
  if (iterations > 0) trainer.setBudget({0, iterations});
  else if (!by_cpu) trainer.setBudget({seconds, 0});
  for (;;) {
    const double used = by_cpu ? cpu_trained : trained;
    if (iterations > 0 ? trainer.iteration() >= iterations : used >= budget - 1e-6) break;
    if (by_cpu && trainer.iteration() > 0) {
      // The schedule decays over the CPU budget: steps expected at the rate so far.
      trainer.setBudget({0, std::max<std::int64_t>(1, static_cast<std::int64_t>(
                                                            trainer.iteration() * cpu_budget / cpu_trained))});
    }
    const double cpu0 = cpuSeconds();
    const auto t0 = std::chrono::steady_clock::now();
    const nerf::StepResult r = trainer.step(1);
    trained += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    cpu_trained += cpuSeconds() - cpu0;
    window.add(r);
    const double now = by_cpu ? cpu_trained : trained;
    if (iterations > 0 && trainer.iteration() % 100 == 0) {
      std::fprintf(stderr, "nerf_train: it %lld  %.1f s (%.1f cpu s)  %.1f samples/ray  occupied %.1f%%\n",
                   static_cast<long long>(trainer.iteration()), trained, cpu_trained,
                   static_cast<double>(r.marched) / std::max<std::int64_t>(1, r.rays),
                   100.0 * trainer.model().grid().occupiedFraction());
    }
    // The last point comes from main's final evaluation.
    if (iterations > 0 || now < next_eval - 1e-9 || now >= budget - 1e-6) continue;
    next_eval += eval_every;
    last = window.progress(trainer, trained);
    const nerf::Evaluation e = nerf::evaluate(trainer.model(), dataset.test, false);
    rows.push_back({trained, last.psnr, e.psnr, last.rays_per_second, last.samples_per_second, last.samples_per_ray,
                    static_cast<long long>(last.iteration), cpu_trained, e.samples_per_pixel});
    std::fprintf(stderr, "nerf_train: %.1f s (%.1f cpu s)  it %lld  train %.2f dB  test %.2f dB  render %.3f s/view, "
                 "%.1f samples/pixel, occupied %.1f%%\n", trained, cpu_trained, rows.back().iteration, last.psnr,
                 e.psnr, e.seconds_per_view, e.samples_per_pixel, 100.0 * last.occupied_fraction);
    window = Window();
    window.seconds = trained;
  }
  last = window.progress(trainer, trained);
  curve.by_cpu = by_cpu;
  return curve;
}

}  // namespace

int main(int argc, char** argv) {
  std::map<std::string, std::string> args;
  for (int i = 1; i + 1 < argc; i += 2) args[std::string(argv[i]).substr(2)] = argv[i + 1];
  auto get = [&](const std::string& k, const std::string& d) { return args.count(k) ? args[k] : d; };
  if (!args.count("data")) {
    std::fprintf(stderr, "usage: nerf_train --data DIR [--seconds 60] [--downscale 1] [--config nerf.yaml] "
                         "[--eval-every 10] [--csv curve.csv] [--plot curve.png] [--model out.nerf] [--iterations N] "
                         "[--cpu-seconds C]\n");
    return 2;
  }
  try {
    const double seconds = std::stod(get("seconds", "60"));
    const double eval_every = std::stod(get("eval-every", "10"));
    core::DatasetOptions options;
    options.downscale = std::stod(get("downscale", "1"));
    const core::Dataset dataset = core::loadDataset(args["data"], options);
    nerf::NerfConfig config = args.count("config") ? nerf::loadNerfConfig(args["config"]) : nerf::NerfConfig{};
    // The entry point's job, not the Trainer's: every core unless the config names a count (Debian's
    // libtorch starts with one thread, and its count is OpenMP's, which the NeRF kernels use).
    at::set_num_threads(config.train.threads > 0 ? config.train.threads
                                                 : static_cast<int>(std::max(1u, std::thread::hardware_concurrency())));
    nerf::Trainer trainer(config, nerf::datasetBox(dataset), dataset.aabb_scale);
    trainer.addFrames(dataset.train);
    std::fprintf(stderr, "nerf_train: %zu train / %zu test views, %dx%d, box %.3g x %.3g x %.3g, aabb_scale %.3g\n",
                 dataset.train.size(), dataset.test.size(), dataset.train[0].camera.width,
                 dataset.train[0].camera.height, dataset.bounds.sizes().x(), dataset.bounds.sizes().y(),
                 dataset.bounds.sizes().z(), dataset.aabb_scale);
    const Curve curve = trainCurve(trainer, dataset,
                                   {std::stoll(get("iterations", "0")), seconds, std::stod(get("cpu-seconds", "0")),
                                    eval_every});
    std::vector<Row> rows = curve.rows;
    const double trained = curve.trained, cpu_trained = curve.cpu_trained;
    const nerf::TrainProgress& last = curve.last;
    const bool by_cpu = curve.by_cpu;
    if (get("final-eval", "1") == "0") {  // profiling runs: the training only
      std::printf("trained_cpu_seconds %.2f\ntrained_seconds %.2f\niterations %lld\n", cpu_trained, trained,
                  static_cast<long long>(trainer.iteration()));
      return 0;
    }
    const nerf::Evaluation final_eval = nerf::evaluate(trainer.model(), dataset.test, true);
    rows.push_back({trained, last.psnr, final_eval.psnr, last.rays_per_second, last.samples_per_second,
                    last.samples_per_ray, static_cast<long long>(trainer.iteration()), cpu_trained,
                    final_eval.samples_per_pixel});
    const nerf::StepTimes& t = trainer.times();
    std::printf("trained_cpu_seconds %.2f\n", cpu_trained);
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
      csv << "seconds,iteration,train_psnr,test_psnr,rays_per_second,samples_per_second,samples_per_ray,cpu_seconds,"
             "render_samples_per_pixel\n";
      for (const Row& r : rows) {
        csv << r.seconds << "," << r.iteration << "," << r.train_psnr << "," << r.test_psnr << "," << r.rays_per_second
            << "," << r.samples_per_second << "," << r.samples_per_ray << "," << r.cpu_seconds << ","
            << r.render_samples_per_pixel << "\n";
      }
    }
    if (args.count("plot")) plot(rows, args["plot"], args["data"], by_cpu);
    if (args.count("model")) nerf::saveModel(trainer.model(), args["model"]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "nerf_train: %s\n", e.what());
    return 1;
  }
  return 0;
}
