#include "mechanics_matrix_settings.hpp"

#include <map>

#include "demnerf/core/error.hpp"
#include "mechanics_bench_common.hpp"
#include "mechanics_matrix_cases.hpp"
#include "mechanics_matrix_report.hpp"

namespace demnerf::bench {

MatrixSettings parseMatrixSettings(int argc, char** argv) {
  std::map<std::string, std::string> a = keyValueArguments(argc, argv);
  const bool quick = a.count("quick") && a["quick"] != "0";
  auto text = [&](const char* key, const std::string& fallback) { return a.count(key) ? a[key] : fallback; };
  auto num = [&](const char* key, double fallback) { return a.count(key) ? std::stod(a[key]) : fallback; };
  std::string all;
  for (const MatrixCase& c : matrixCases()) all += (all.empty() ? "" : ",") + c.name;
  MatrixSettings s;
  s.scenarios = splitList(text("scenarios", quick ? "beam3d" : all));
  s.samplers = splitList(text("samplers", quick ? "grid" : "random,poisson,grid"));
  s.sources = splitList(text("sources", quick ? "exact" : "exact,nerf"));
  s.solvers = splitList(text("solvers", quick ? "fem,dem" : "fem,dem,dem_mlp,dem_mlp_exact,dem_mlp_gn"));
  for (const std::string& d : splitList(text("spacings", quick ? "6" : "6,10,15")))
    s.divisors.push_back(std::stoi(d));
  s.time_limit = num("time_limit", s.time_limit);
  s.ref_time_limit = num("ref_time_limit", s.ref_time_limit);
  s.fem_div = num("fem_div", s.fem_div);
  s.nerf_seconds = num("nerf_seconds", s.nerf_seconds);
  s.nerf_cpu_seconds = num("nerf_cpu_seconds", s.nerf_cpu_seconds);
  for (const auto& [key, value] : {std::pair<const char*, int*>{"mlp_iters", &s.mlp_iters}, {"mlp_lbfgs", &s.mlp_lbfgs},
                                   {"gn_steps", &s.gn_steps}, {"ref_div", &s.ref_div}, {"conv_div", &s.conv_div},
                                   {"seed", &s.seed}})
    *value = static_cast<int>(num(key, *value));
  s.grid_spacings = num("grid_spacings", s.grid_spacings);
  s.extension_fill = num("ext_fill", s.extension_fill);
  s.body_cells = num("body_cells", s.body_cells);
  s.boundary_levels = static_cast<int>(num("levels", s.boundary_levels));
  s.yaml = text("yaml", "");
  s.config = text("config", "");
  s.clouds = text("clouds", "");
  s.nerf_config = text("nerf_config", "");
  s.rows = splitList(text("rows", ""));
  if (!s.yaml.empty() && s.scenarios.size() != 1) throw core::Error("yaml= needs exactly one scenario in scenarios=");
  s.partial = !s.yaml.empty() || !s.config.empty() || !s.nerf_config.empty() || !s.rows.empty() || s.scenarios.size() < matrixCases().size() ||
              s.samplers.size() < 3 || s.sources.size() < 2 || s.solvers.size() < 4 || s.divisors.size() < 3;
  s.out = text("out", std::string(DEMNERF_ROOT) + "/output/bench/mechanics_matrix");
  s.docs = text("docs", s.partial ? "" : std::string(DEMNERF_ROOT) + "/docs");
  s.title = "mechanics_matrix";
  for (int i = 1; i < argc; ++i) s.title += std::string(" ") + argv[i];
  return s;
}

}  // namespace demnerf::bench
