// DEM convergence curves: relative L2 displacement error against training wall time for several
// optimiser set-ups, on the uniaxial cube (closed form) or the T-bar twist (a FEM reference
// written by mechanics_dem case=tbar or mechanics_tbar_fem). Writes a CSV and a PNG plot.
//   mechanics_convergence case=uniaxial|tbar [reference=PATH] [iters=N] [every=N] [width=W]
//                         [depth=D] [out=PREFIX]
// Evaluation time is excluded from the time axis.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "demnerf/core/ply.hpp"
#include "demnerf/core/scenario.hpp"
#include "demnerf/mechanics/process_settings.hpp"
#include "demnerf/mechanics/box_particles.hpp"
#include "demnerf/mechanics/dem_solver.hpp"
#include "demnerf/mechanics/material.hpp"
#include "demnerf/mechanics/reference_problems.hpp"
#include "mechanics_bench_common.hpp"

using namespace demnerf;
using namespace demnerf::bench;
namespace dm = demnerf::mechanics;

namespace {

struct Sample {
  double seconds, error;
};

struct Variant {
  std::string name;
  dm::DemConfig config;
  cv::Scalar colour;
  std::vector<Sample> curve;
};

// Log-log plot: error (1e-3 .. 1) against seconds (1e-3 .. tmax).
void plot(const std::vector<Variant>& variants, const std::string& path, const std::string& title) {
  const int w = 720, h = 440, m = 60;
  cv::Mat img(h, w, CV_8UC3, cv::Scalar(255, 255, 255));
  double tmax = 1.0;
  for (const auto& v : variants)
    for (const auto& s : v.curve) tmax = std::max(tmax, s.seconds);
  const double lt0 = -3, lt1 = std::ceil(std::log10(tmax)), le0 = -3, le1 = 0;
  auto px = [&](double t, double e) {
    const double x = (std::log10(std::max(t, 1e-3)) - lt0) / (lt1 - lt0);
    const double y = (std::clamp(std::log10(std::max(e, 1e-3)), le0, le1) - le0) / (le1 - le0);
    return cv::Point(m + static_cast<int>((w - 2 * m) * x), h - m - static_cast<int>((h - 2 * m) * y));
  };
  cv::rectangle(img, px(1e-3, 1e-3), px(std::pow(10.0, lt1), 1.0), cv::Scalar(0, 0, 0));
  for (double le = le0; le <= le1; le += 1) {
    cv::line(img, px(1e-3, std::pow(10.0, le)), px(std::pow(10.0, lt1), std::pow(10.0, le)), cv::Scalar(220, 220, 220));
    char label[16];
    std::snprintf(label, sizeof(label), "%g%%", 100 * std::pow(10.0, le));
    cv::putText(img, label, px(1e-3, std::pow(10.0, le)) + cv::Point(-52, 4), cv::FONT_HERSHEY_SIMPLEX, 0.4,
                cv::Scalar(0, 0, 0));
  }
  for (double lt = lt0; lt <= lt1; lt += 1) {
    char label[16];
    std::snprintf(label, sizeof(label), "%gs", std::pow(10.0, lt));
    cv::putText(img, label, px(std::pow(10.0, lt), 1e-3) + cv::Point(-12, 18), cv::FONT_HERSHEY_SIMPLEX, 0.4,
                cv::Scalar(0, 0, 0));
  }
  cv::line(img, px(1e-3, 0.05), px(std::pow(10.0, lt1), 0.05), cv::Scalar(0, 0, 200), 1);  // the 5 % target
  int legend = 0;
  for (const auto& v : variants) {
    for (std::size_t i = 1; i < v.curve.size(); ++i)
      cv::line(img, px(v.curve[i - 1].seconds, v.curve[i - 1].error), px(v.curve[i].seconds, v.curve[i].error),
               v.colour, 2);
    for (const auto& s : v.curve) cv::circle(img, px(s.seconds, s.error), 2, v.colour, -1);
    // Legend in the bottom-right corner: small errors late in training, where no curve has been.
    cv::putText(img, v.name, cv::Point(w - m - 200, h - m - 10 - 18 * static_cast<int>(variants.size() - 1 - legend++)),
                cv::FONT_HERSHEY_SIMPLEX, 0.45, v.colour, 1);
  }
  cv::putText(img, title, cv::Point(m, 25), cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0));
  cv::imwrite(path, img);
}

using Arguments = std::map<std::string, std::string>;

double number(const Arguments& a, const char* key, double fallback) {
  const auto it = a.find(key);
  return it != a.end() ? std::atof(it->second.c_str()) : fallback;
}

struct Problem {
  core::Scenario scenario;
  core::ParticleCloud cloud;
  std::vector<Vector3d> reference;  ///< empty when the T-bar's FEM reference could not be read
};

/// The uniaxial cube against its closed form, or the T-bar twist against a FEM reference: a
/// result PLY on the same particles (mechanics_tbar_fem ref_out=...) or mechanics_dem's cache.
Problem loadProblem(const Arguments& a, const std::string& which) {
  Problem p;
  if (which == "uniaxial") {
    p.cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(1, 1, 1), Eigen::Vector3i(6, 6, 6));
    p.scenario = dm::uniaxialTractionScenario(2e5);
    double b = 0;
    const double s = dm::uniaxialStretchForStress(*dm::makeMaterial(p.scenario.material), 2e5, &b);
    for (const auto& X : p.cloud.positions) p.reference.emplace_back((s - 1) * X.x(), (b - 1) * X.y(), (b - 1) * X.z());
    return p;
  }
  p.scenario = core::loadScenario(std::string(DEMNERF_ROOT) + "/config/scenarios/tbar_twist.yaml");
  p.cloud = tbarParticles(0.0075);
  const std::string path = a.count("reference") ? a.at("reference") : "/tmp/dem_tbar_fem_0.007500_0.010000.bin";
  bool ok = false;
  if (path.size() > 4 && path.substr(path.size() - 4) == ".ply") {
    const core::ResultField r = core::readResult(path);
    ok = r.size() == p.cloud.size();
    p.reference = r.displacements;
  } else {
    std::ifstream in(path, std::ios::binary);
    p.reference.resize(p.cloud.size());
    in.read(reinterpret_cast<char*>(p.reference.data()),
            static_cast<std::streamsize>(p.reference.size() * sizeof(Vector3d)));
    ok = static_cast<bool>(in);
  }
  if (!ok) {
    std::fprintf(stderr, "no T-bar FEM reference at %s: run mechanics_dem case=tbar (it writes one) or pass reference=\n",
                 path.c_str());
    p.reference.clear();
  }
  return p;
}

/// The optimiser set-ups compared, all on the MLP alone.
std::vector<Variant> makeVariants(const Arguments& a, const std::string& which, int iters) {
  dm::DemConfig base;
  base.network.width = static_cast<int>(number(a, "width", which == "tbar" ? 32 : 16));
  base.network.depth = static_cast<int>(number(a, "depth", which == "tbar" ? 3 : 2));
  base.adam.iterations = iters;
  base.grid.spacings = 0.0;  // the MLP alone (DemConfig's default is the feature-grid DEM)
  base.grid.body_cells = 0.0;
  std::vector<Variant> variants;
  variants.push_back({"Adam", base, cv::Scalar(200, 60, 0), {}});
  dm::DemConfig polish = base;
  polish.adam.iterations = std::min(100, iters);
  polish.lbfgs.iterations = iters;
  variants.push_back({"Adam 100 + L-BFGS", polish, cv::Scalar(0, 150, 0), {}});
  dm::DemConfig newton = base;
  newton.output_newton.enabled = true;
  newton.adam.iterations = 0;
  variants.push_back({"output-layer Newton", newton, cv::Scalar(0, 0, 0), {}});
  dm::DemConfig newton_adam = base;
  newton_adam.output_newton.enabled = true;
  newton_adam.output_newton.every = 50;
  newton_adam.adam.learning_rate = 1e-4;
  variants.push_back({"Newton + Adam 1e-4", newton_adam, cv::Scalar(160, 0, 160), {}});
  return variants;
}

/// One training, its error recorded every `every` iterations (evaluation time excluded) into
/// the variant's curve and the CSV; prints its table row.
void runVariant(const Problem& p, const std::string& which, int every, Variant& v, std::ofstream& csv) {
  dm::DemSolver dem(p.cloud, p.scenario, v.config);
  double eval_seconds = 0.0;
  const auto start = std::chrono::steady_clock::now();
  auto record = [&](int iteration) {
    const auto t0 = std::chrono::steady_clock::now();
    const double err = relativeL2(dem.predict(p.cloud.positions), p.reference);
    const double elapsed = std::chrono::duration<double>(t0 - start).count() - eval_seconds;
    eval_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    v.curve.push_back({elapsed, err});
    csv << v.name << "," << iteration << "," << elapsed << "," << err << "\n";
  };
  dem.setProgressCallback(record, every);
  try {
    const dm::DemReport r = dem.solve();
    record(r.iterations);
    std::printf("| %s | %s | %zu | %dx%d | %d | %.2f | %.4f |\n", which.c_str(), v.name.c_str(), p.cloud.size(),
                v.config.network.width, v.config.network.depth, r.iterations, v.curve.back().seconds,
                v.curve.back().error);
  } catch (const std::exception& e) {
    std::printf("| %s | %s | %zu | %dx%d | - | - | failed: %s |\n", which.c_str(), v.name.c_str(), p.cloud.size(),
                v.config.network.width, v.config.network.depth, e.what());
  }
}

}  // namespace

int main(int argc, char** argv) {
  demnerf::mechanics::keepLargeAllocationsInHeap();  // as the product's entry points do (tune_allocator)
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  const Arguments a = demnerf::bench::keyValueArguments(argc, argv);
  const std::string which = a.count("case") ? a.at("case") : "uniaxial";
  const std::string out = a.count("out") ? a.at("out") : "dem_convergence_" + which;
  const int iters = static_cast<int>(number(a, "iters", which == "tbar" ? 600 : 1000));
  const int every = static_cast<int>(number(a, "every", 25));
  Problem problem = loadProblem(a, which);
  if (problem.reference.empty()) return 1;
  problem.scenario.load_steps = 1;
  std::vector<Variant> variants = makeVariants(a, which, iters);

  std::ofstream csv(out + ".csv");
  csv << "variant,iteration,seconds,rel_l2\n";
  std::printf("| case | variant | particles | net | iterations | time (s) | rel L2 |\n| --- | --- | --- | --- | --- | --- | --- |\n");
  for (Variant& v : variants) runVariant(problem, which, every, v, csv);
  plot(variants, out + ".png", "DEM rel. L2 error vs training seconds, " + which + " (" +
                                   std::to_string(problem.cloud.size()) + " particles)");
  std::printf("wrote %s.csv and %s.png\n", out.c_str(), out.c_str());
  return 0;
}
