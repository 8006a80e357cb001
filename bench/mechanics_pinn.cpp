// PINN baseline bench: the strong-form PINN (packages/mechanics/pinn_solver) on the uniaxial
// roller cube (closed form) and the T-bar twist (FEM reference), one row per seed with solver,
// particles, seconds and relative L2 displacement error: the README's solver x time x error rows.
// Usage: mechanics_pinn key=value ...
//   case=uniaxial|tbar|both (default both)  seeds=N (3)  iters=N lr=R final=RATIO lbfgs=N
//   jitter=0|1  uscale=M (displacement scale, 0: estimated)  rescale=N (amplitude refit every N Adam its, 0: off)  batch=N (residual particles per Adam step, 0: all) width=W depth=D activation=tanh|sin|softplus wr=W_R wt=W_t wu=W_u steps=LOAD_STEPS
//   threads=T double=0|1 verbose=0|1  cells=N (uniaxial cube cells per axis, 6)
//   h=M (T-bar particle cell, 0.0075)  ref=PATH (T-bar reference: a result PLY of
//   mechanics_tbar_fem ref_out=..., or the .bin cache bench/mechanics_dem case=tbar writes;
//   default: that cache for h and fem_h=0.01)  scenario=PATH
// The T-bar reference is not computed here: the FEM reference belongs to the FEM benches.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include "demnerf/core/error.hpp"
#include "demnerf/core/ply.hpp"
#include "demnerf/core/scenario.hpp"
#include "demnerf/mechanics/process_settings.hpp"
#include "demnerf/mechanics/box_particles.hpp"
#include "demnerf/mechanics/material.hpp"
#include "demnerf/mechanics/pinn_solver.hpp"
#include "demnerf/mechanics/reference_problems.hpp"
#include "mechanics_bench_common.hpp"

namespace dm = demnerf::mechanics;
namespace core = demnerf::core;
using Eigen::Vector3d;
using demnerf::bench::median;
using demnerf::bench::tbarParticles;

namespace {

struct Case {
  std::string name;
  core::ParticleCloud cloud;
  core::Scenario scenario;
  std::vector<Vector3d> reference;  // displacement at each particle
};

// Unit cube on rollers pulled by P11 = 200 kPa on x = 1 (the DEM tests' and bench's set-up).
Case uniaxialCase(int cells) {
  Case c;
  c.name = "uniaxial";
  c.cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(1, 1, 1), Eigen::Vector3i(cells, cells, cells));
  core::Scenario& s = c.scenario;
  s = dm::uniaxialTractionScenario(2e5);
  double b = 0;
  const double a = dm::uniaxialStretchForStress(*dm::makeMaterial(s.material), 2e5, &b);
  for (const auto& X : c.cloud.positions) c.reference.emplace_back((a - 1) * X.x(), (b - 1) * X.y(), (b - 1) * X.z());
  return c;
}

// The T-bar twist on grid particles, with a FEM reference read from disk (a result PLY whose rows
// are the same particles, or the raw Vector3d cache of bench/mechanics_dem).
Case tbarCase(double h, const std::string& scenario, const std::string& ref) {
  Case c;
  c.name = "tbar";
  c.cloud = tbarParticles(h);
  c.scenario = core::loadScenario(scenario);
  if (ref.size() > 4 && ref.substr(ref.size() - 4) == ".ply") {
    const core::ResultField r = core::readResult(ref);
    if (r.size() != c.cloud.size())
      throw core::Error("reference " + ref + " has " + std::to_string(r.size()) + " rows, the T-bar particles " +
                        std::to_string(c.cloud.size()) + ": was it written for h=" + std::to_string(h) + "?");
    for (std::size_t i = 0; i < r.size(); ++i)
      if ((r.positions[i] - c.cloud.positions[i]).norm() > 1e-6)
        throw core::Error("reference " + ref + " row " + std::to_string(i) + " is not at the T-bar particle");
    c.reference = r.displacements;
  } else {
    std::ifstream in(ref, std::ios::binary);
    c.reference.resize(c.cloud.size());
    if (in) in.read(reinterpret_cast<char*>(c.reference.data()), static_cast<std::streamsize>(c.reference.size() * sizeof(Vector3d)));
    if (!in || in.peek() != std::char_traits<char>::eof())
      throw core::Error("no T-bar FEM reference for h=" + std::to_string(h) + " at " + ref +
                        ": run `mechanics_dem case=tbar h=<h> fem_h=<fem_h> iters=1 seeds=1` (writes that cache) or "
                        "`mechanics_tbar_fem ref_out=R.ply particle_h=<h>` and pass ref=R.ply");
  }
  return c;
}

}  // namespace

int main(int argc, char** argv) {
  demnerf::mechanics::keepLargeAllocationsInHeap();  // as the product's entry points do (tune_allocator)
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  std::map<std::string, std::string> a = demnerf::bench::keyValueArguments(argc, argv);
  auto num = [&](const char* k, double d) { return a.count(k) ? std::atof(a[k].c_str()) : d; };
  const std::string which = a.count("case") ? a["case"] : "both";
  dm::PinnConfig config;
  config.adam_iterations = static_cast<int>(num("iters", config.adam_iterations));
  config.adam_learning_rate = num("lr", config.adam_learning_rate);
  config.adam_final_rate_ratio = num("final", config.adam_final_rate_ratio);
  config.lbfgs_iterations = static_cast<int>(num("lbfgs", config.lbfgs_iterations));
  config.width = static_cast<int>(num("width", config.width));
  config.depth = static_cast<int>(num("depth", config.depth));
  config.weight_residual = num("wr", config.weight_residual);
  config.weight_traction = num("wt", config.weight_traction);
  config.weight_displacement = num("wu", config.weight_displacement);
  config.load_steps = static_cast<int>(num("steps", config.load_steps));
  config.residual_batch = static_cast<int>(num("batch", config.residual_batch));
  config.jitter = num("jitter", 1) != 0;
  config.displacement_scale = num("uscale", config.displacement_scale);
  config.rescale_every = static_cast<int>(num("rescale", config.rescale_every));
  config.threads = static_cast<int>(num("threads", 0));
  config.double_precision = num("double", 0) != 0;
  config.verbose = num("verbose", 0) != 0;
  if (a.count("activation")) config.activation = a["activation"];
  const int seeds = static_cast<int>(num("seeds", 3));

  try {
    std::vector<Case> cases;
    if (which == "uniaxial" || which == "both") cases.push_back(uniaxialCase(static_cast<int>(num("cells", 6))));
    if (which == "tbar" || which == "both") {
      const double h = num("h", 0.0075), fem_h = num("fem_h", 0.01);
      char cache[128];
      std::snprintf(cache, sizeof cache, "/tmp/dem_tbar_fem_%f_%f.bin", h, fem_h);
      cases.push_back(tbarCase(h,
                               a.count("scenario") ? a["scenario"] : std::string(DEMNERF_ROOT) + "/config/scenarios/tbar_twist.yaml",
                               a.count("ref") ? a["ref"] : std::string(cache)));
    }
    if (cases.empty()) throw core::Error("case must be uniaxial, tbar or both, got '" + which + "'");
    std::printf("| solver | case | particles | net | Adam x steps (batch) | L-BFGS | W_R, W_t, W_u | seed | time (s) | rel L2 | "
                "max err / max |u| | max |u| (mm): pinn / ref | loss (R, t, u) |\n");
    for (const Case& c : cases) {
      double ref_norm = 0, ref_max = 0;
      for (const auto& r : c.reference) {
        ref_norm += r.squaredNorm();
        ref_max = std::max(ref_max, r.norm());
      }
      std::vector<double> seconds, errors;
      for (int seed = 1; seed <= seeds; ++seed) {
        config.seed = seed;
        dm::PinnSolver pinn(c.cloud, c.scenario, config);
        const dm::PinnReport r = pinn.solve();
        const auto u = pinn.predict(c.cloud.positions);
        double e = 0, emax = 0, umax = 0;
        for (std::size_t i = 0; i < u.size(); ++i) {
          umax = std::max(umax, u[i].norm());
          e += (u[i] - c.reference[i]).squaredNorm();
          emax = std::max(emax, (u[i] - c.reference[i]).norm());
        }
        seconds.push_back(r.seconds);
        errors.push_back(std::sqrt(e / ref_norm));
        std::printf("| pinn | %s | %zu | %dx%d %s %s | %d x %d (%d) | %d | %g, %g, %g | %d | %.2f | %.4f | %.4f | %.2f / %.2f | %.3g (%.3g, %.3g, %.3g) |\n",
                    c.name.c_str(), c.cloud.size(), config.width, config.depth, config.activation.c_str(),
                    config.double_precision ? "f64" : "f32", config.adam_iterations, r.load_steps, config.residual_batch, config.lbfgs_iterations,
                    config.weight_residual, config.weight_traction, config.weight_displacement, seed, r.seconds,
                    errors.back(), emax / ref_max, 1e3 * umax, 1e3 * ref_max, r.loss, r.residual_mse, r.traction_mse, r.displacement_mse);
      }
      std::printf("median %s: time %.2f s, rel L2 %.4f (min %.4f, max %.4f), %zu particles\n", c.name.c_str(),
                  median(seconds), median(errors), *std::min_element(errors.begin(), errors.end()),
                  *std::max_element(errors.begin(), errors.end()), c.cloud.size());
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "mechanics_pinn: %s\n", e.what());
    return 1;
  }
  return 0;
}
