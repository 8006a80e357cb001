#include "demnerf/mechanics/solver_config_yaml.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <limits>
#include <sstream>
#include <utility>

#include "demnerf/core/error.hpp"

namespace demnerf::mechanics {
namespace {

using core::Error;

// One row per key: where it lives, what it means, and how it is read (returning what is wrong with
// a value, empty when it was taken) and written. One table drives reading, writing and the key
// list, so the example file, the loader and the tests cannot disagree.
struct Field {
  std::string section;  ///< "" for a top-level key
  std::string key;
  std::string meaning;
  std::function<std::string(const YAML::Node&)> read;
  std::function<std::string()> write;
};

std::string formatNumber(double value) {
  char text[64];
  std::snprintf(text, sizeof text, "%.15g", value);
  return text;
}

constexpr double kInf = std::numeric_limits<double>::infinity();

Field integer(std::string section, std::string key, int& field, int lo, int hi, std::string meaning) {
  return {std::move(section), std::move(key), std::move(meaning),
          [&field, lo, hi](const YAML::Node& node) -> std::string {
            const std::string range = hi == std::numeric_limits<int>::max()
                                          ? ">= " + std::to_string(lo)
                                          : "in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
            long long value = 0;
            try {
              value = node.as<long long>();
            } catch (const YAML::Exception&) {
              return "must be an integer " + range + ", got '" + YAML::Dump(node) + "'";
            }
            if (value < lo || value > hi) return "must be an integer " + range + ", got " + std::to_string(value);
            field = static_cast<int>(value);
            return "";
          },
          [&field] { return std::to_string(field); }};
}

/// A finite number in [lo, hi] (lo excluded when `lo_open`).
Field number(std::string section, std::string key, double& field, double lo, bool lo_open, double hi,
             std::string meaning) {
  return {std::move(section), std::move(key), std::move(meaning),
          [&field, lo, lo_open, hi](const YAML::Node& node) -> std::string {
            std::string range = std::isinf(hi) ? (lo_open ? "> " : ">= ") + formatNumber(lo)
                                               : std::string(lo_open ? "in (" : "in [") + formatNumber(lo) + ", " +
                                                     formatNumber(hi) + "]";
            if (std::isinf(lo) && std::isinf(hi)) range = "(finite)";
            double value = 0.0;
            try {
              value = node.as<double>();
            } catch (const YAML::Exception&) {
              return "must be a number " + range + ", got '" + YAML::Dump(node) + "'";
            }
            if (!std::isfinite(value) || value < lo || (lo_open && value == lo) || value > hi)
              return "must be a number " + range + ", got " + YAML::Dump(node);
            field = value;
            return "";
          },
          [&field] { return formatNumber(field); }};
}

Field flag(std::string section, std::string key, bool& field, std::string meaning) {
  return {std::move(section), std::move(key), std::move(meaning),
          [&field](const YAML::Node& node) -> std::string {
            try {
              field = node.as<bool>();
            } catch (const YAML::Exception&) {
              return "must be true or false, got '" + YAML::Dump(node) + "'";
            }
            return "";
          },
          [&field] { return std::string(field ? "true" : "false"); }};
}

/// A string or an enum spelled as one of `names` (in the order of `values`).
template <class T>
Field choice(std::string section, std::string key, T& field, std::vector<std::pair<std::string, T>> names,
             std::string meaning) {
  std::string list;
  for (const auto& n : names) list += (list.empty() ? "" : ", ") + n.first;
  return {std::move(section), std::move(key), std::move(meaning) + " (" + list + ")",
          [&field, names, list](const YAML::Node& node) -> std::string {
            std::string value;
            try {
              value = node.as<std::string>();
            } catch (const YAML::Exception&) {
              return "must be one of " + list + ", got '" + YAML::Dump(node) + "'";
            }
            for (const auto& n : names)
              if (n.first == value) {
                field = n.second;
                return "";
              }
            return "must be one of " + list + ", got '" + value + "'";
          },
          [&field, names] {
            for (const auto& n : names)
              if (n.second == field) return n.first;
            return std::string("?");
          }};
}

std::vector<std::pair<std::string, std::string>> words(std::initializer_list<const char*> list) {
  std::vector<std::pair<std::string, std::string>> out;
  for (const char* w : list) out.emplace_back(w, w);
  return out;
}

std::vector<Field> demFields(DemConfig& c) {
  const std::string s = "dem";
  const int many = std::numeric_limits<int>::max();
  using B = DemConfig::Boundary;
  using Q = DemConfig::GridQuadrature;
  return {
      integer(s, "width", c.width, 1, many, "hidden units per layer of the MLP"),
      integer(s, "depth", c.depth, 1, many, "hidden layers of the MLP"),
      choice(s, "activation", c.activation, words({"tanh", "sigmoid", "softplus", "sin"}), "MLP activation"),
      choice<B>(s, "boundary", c.boundary, {{"exact", B::kExact}, {"penalty", B::kPenalty}},
                "fixtures held exactly, u = g + D z, or by the paper's penalty W_u MSE_u"),
      number(s, "penalty_weight", c.penalty_weight, 0, true, kInf, "W_u of the penalty boundary"),
      integer(s, "adam_iterations", c.adam_iterations, 0, many, "Adam steps per load step (0: grid Newton only)"),
      number(s, "adam_learning_rate", c.adam_learning_rate, 0, true, kInf, "Adam's initial learning rate"),
      number(s, "adam_final_rate_ratio", c.adam_final_rate_ratio, 0, true, 1, "learning rate at a step's end / start"),
      integer(s, "rescale_every", c.rescale_every, 0, many, "output amplitude line search every N Adam steps (0: never)"),
      integer(s, "rescale_until", c.rescale_until, 0, many, "...during the first N Adam steps"),
      flag(s, "output_newton", c.output_newton, "Newton on the MLP's output layer (exact boundary, no grid)"),
      integer(s, "newton_every", c.newton_every, 0, many, "output-layer Newton every N Adam steps (0: only after)"),
      integer(s, "newton_iterations", c.newton_iterations, 0, many, "output-layer Newton iterations"),
      number(s, "grid_cell", c.grid_cell, 0, false, kInf, "feature grid cell edge in m (0: from grid_spacings)"),
      number(s, "grid_spacings", c.grid_spacings, 0, false, kInf,
             "feature grid cell in particle spacings (0 with grid_cell 0: MLP alone)"),
      integer(s, "grid_degree", c.grid_degree, 1, 3, "B-spline degree of the feature grid"),
      integer(s, "grid_newton_iterations", c.grid_newton_iterations, 0, many, "Newton iterations of the grid solve"),
      number(s, "grid_refine_band", c.grid_refine_band, 0, false, kInf,
             "cells near fixtures/loads whose particles are split 2x2x2"),
      number(s, "grid_surface_share", c.grid_surface_share, 0, false, 1,
             "share of energyWeights() in the grid quadrature weights (particles quadrature)"),
      choice<Q>(s, "grid_quadrature", c.grid_quadrature, {{"cells", Q::kCells}, {"particles", Q::kParticles}},
                "grid Newton quadrature: Gauss points in the cells inside the body, or the particles"),
      integer(s, "grid_gauss_points", c.grid_gauss_points, 1, 3, "Gauss points per axis and cell (cells quadrature)"),
      integer(s, "grid_boundary_levels", c.grid_boundary_levels, 0, 4,
              "times a cut cell is split 2x2x2 before moment fitting (cells quadrature)"),
      number(s, "grid_body_cells", c.grid_body_cells, 0, false, kInf,
             "cells the body's volume holds, sizing the grid (0: from grid_cell or grid_spacings)"),
      number(s, "grid_extension_fill", c.grid_extension_fill, 0, false, 1,
             "nodes touching no cell filled this much are extrapolated (extended B-splines; 0: off)"),
      integer(s, "load_steps", c.load_steps, 0, many, "load steps (0: the scenario's, 1 with the grid)"),
      flag(s, "jitter", c.jitter, "particles near fixtures/loads move within their cell every Adam step"),
      number(s, "jitter_band", c.jitter_band, 0, false, kInf, "cells from a fixture that are jittered"),
      integer(s, "lbfgs_iterations", c.lbfgs_iterations, 0, many, "L-BFGS polish per load step (0: off)"),
      integer(s, "lbfgs_history", c.lbfgs_history, 1, many, "L-BFGS history length"),
      number(s, "polish_max_energy_drop", c.polish_max_energy_drop, 0, true, kInf,
             "reject a polish that lowers the energy more than this x |Pi|"),
      number(s, "polish_max_growth", c.polish_max_growth, 0, true, kInf,
             "reject a polish that grows max |u| more than this factor"),
      number(s, "tolerance", c.tolerance, 0, false, kInf, "L-BFGS stops when the loss changes less than this"),
      integer(s, "max_halvings", c.max_halvings, 0, many, "load-step halvings after a failed step"),
      integer(s, "threads", c.threads, 0, many, "torch threads (0: 1 below 50k particles, else all cores)"),
      flag(s, "tune_allocator", c.tune_allocator, "raise glibc's mmap threshold (reuses Adam's buffers)"),
      flag(s, "parametric", c.parametric, "train over load fractions [load_range_min, load_range_max] (MLP alone)"),
      number(s, "load_range_min", c.load_range_min, -kInf, false, kInf, "parametric: smallest load fraction"),
      number(s, "load_range_max", c.load_range_max, -kInf, false, kInf, "parametric: largest load fraction (>= 1)"),
      integer(s, "parametric_samples", c.parametric_samples, 1, many, "parametric: load fractions per Adam step"),
      integer(s, "seed", c.seed, std::numeric_limits<int>::min(), many, "random seed"),
      flag(s, "double_precision", c.double_precision, "float64 instead of float32"),
      flag(s, "verbose", c.verbose, "print training details"),
  };
}

std::vector<Field> femFields(FemConfig& c) {
  const std::string s = "fem";
  const int many = std::numeric_limits<int>::max();
  using L = FemConfig::LinearSolver;
  using O = FemConfig::Ordering;
  return {
      choice<L>(s, "linear_solver", c.linear_solver, {{"ldlt", L::kLDLT}, {"cg", L::kConjugateGradient}},
                "sparse linear solver of each Newton step"),
      choice<O>(s, "ordering", c.ordering, {{"amd", O::kAmd}, {"nested_dissection", O::kNestedDissection}},
                "fill-reducing order of the LDLT"),
      integer(s, "max_newton_iterations", c.max_newton_iterations, 1, many, "Newton iterations per load step"),
      integer(s, "load_steps", c.load_steps, 0, many, "load increments (0: the scenario's)"),
      integer(s, "threads", c.threads, 0, many, "assembly threads (0: all cores)"),
      integer(s, "reuse_factorisation_iterations", c.reuse_factorisation_iterations, 0, many,
              "LDLT reused as CG preconditioner until CG needs more (0: refactorise)"),
      number(s, "tolerance", c.tolerance, 0, true, kInf, "|residual| <= this x (|external| + |internal| forces)"),
      number(s, "displacement_tolerance", c.displacement_tolerance, 0, false, kInf,
             "...or the last update below this x |u|"),
      integer(s, "max_step_halvings", c.max_step_halvings, 0, many, "halvings of a failed load step"),
      number(s, "cg_tolerance", c.cg_tolerance, 0, true, kInf, "relative tolerance of the CG solves"),
      flag(s, "verbose", c.verbose, "print Newton iterations"),
  };
}

std::vector<Field> pinnFields(PinnConfig& c) {
  const std::string s = "pinn";
  const int many = std::numeric_limits<int>::max();
  return {
      integer(s, "width", c.width, 1, many, "hidden units per layer"),
      integer(s, "depth", c.depth, 1, many, "hidden layers"),
      choice(s, "activation", c.activation, words({"tanh", "sin", "softplus"}), "MLP activation"),
      number(s, "weight_residual", c.weight_residual, 0, false, kInf, "W_R on the equilibrium residual"),
      number(s, "weight_traction", c.weight_traction, 0, false, kInf, "W_t on the traction residual"),
      number(s, "weight_displacement", c.weight_displacement, 0, false, kInf, "W_u on the displacement residual"),
      integer(s, "adam_iterations", c.adam_iterations, 0, many, "Adam steps per load step"),
      integer(s, "residual_batch", c.residual_batch, 0, many, "residual particles per Adam step (0: all)"),
      flag(s, "jitter", c.jitter, "residual points move within their cell every step"),
      number(s, "adam_learning_rate", c.adam_learning_rate, 0, true, kInf, "Adam's initial learning rate"),
      number(s, "adam_final_rate_ratio", c.adam_final_rate_ratio, 0, true, 1, "learning rate at a step's end / start"),
      integer(s, "rescale_every", c.rescale_every, 0, many, "output amplitude line search every N steps (0: never)"),
      integer(s, "rescale_until", c.rescale_until, 0, many, "...during the first N steps"),
      number(s, "displacement_scale", c.displacement_scale, 0, false, kInf, "m per unit output (0: estimated)"),
      integer(s, "lbfgs_iterations", c.lbfgs_iterations, 0, many, "L-BFGS polish per load step (0: off)"),
      integer(s, "lbfgs_history", c.lbfgs_history, 1, many, "L-BFGS history length"),
      integer(s, "load_steps", c.load_steps, 0, many, "load steps (0: the scenario's)"),
      integer(s, "max_halvings", c.max_halvings, 0, many, "load-step halvings after a failed step"),
      integer(s, "threads", c.threads, 0, many, "torch threads (0: 1 below 50k particles, else all cores)"),
      integer(s, "seed", c.seed, std::numeric_limits<int>::min(), many, "random seed"),
      flag(s, "double_precision", c.double_precision, "float64 instead of float32"),
      flag(s, "verbose", c.verbose, "print training details"),
  };
}

std::vector<Field> fields(SimulateOptions& o) {
  std::vector<Field> all = demFields(o.dem);
  auto append = [&all](std::vector<Field> more) {
    for (Field& f : more) all.push_back(std::move(f));
  };
  append(femFields(o.fem));
  append(pinnFields(o.pinn));
  append({number("voxel", "cell", o.voxel.cell, 0, false, kInf,
                 "FEM mesh size in m: hex edge, or CGAL tetrahedron edge (0: automatic)"),
          integer("voxel", "order", o.voxel.order, 1, 2, "FEM elements: 1 TET4, 2 TET10"),
          number("voxel", "elements_across", o.voxel.elements_across, 0, true, kInf,
                 "automatic FEM cell: the body's thickness over this many elements"),
          number("voxel", "max_dofs", o.voxel.max_dofs, 1, false, kInf,
                 "automatic FEM cell: coarsened until the mesh is expected to hold at most this many dofs")});
  using M = SimulateOptions::Mesher;
  append({choice<M>("", "mesher", o.mesher, {{"cgal", M::kCgal}, {"voxel", M::kVoxel}},
                    "how the FEM meshes a surface (--mesh)")});
  append({number("control", "time_limit", o.control.time_limit, 0, false, kInf, "s per solve (0: no limit)"),
          number("control", "progress_interval", o.control.progress_interval, 0, false, kInf,
                 "s between progress reports")});
  return all;
}

const std::vector<std::string>& sectionNames() {
  static const std::vector<std::string> names{"dem", "fem", "pinn", "voxel", "control"};
  return names;
}

void readField(const Field& field, const YAML::Node& value, const std::string& source) {
  const std::string name = field.section.empty() ? field.key : field.section + "." + field.key;
  const std::string problem = field.read(value);
  if (!problem.empty()) throw Error(source + ": '" + name + "' " + problem);
}

void readSections(const YAML::Node& root, const std::vector<Field>& table, const std::string& source) {
  for (const auto& entry : root) {
    const std::string name = entry.first.as<std::string>();
    bool is_section = false;
    for (const std::string& s : sectionNames()) is_section |= s == name;
    if (!is_section) {
      const Field* top = nullptr;
      for (const Field& f : table)
        if (f.section.empty() && f.key == name) top = &f;
      if (!top)
        throw Error(source + ": unknown key '" + name + "' (known: dem, fem, pinn, voxel, control, mesher)");
      readField(*top, entry.second, source);
      continue;
    }
    if (entry.second.IsNull()) continue;  // "dem:" with nothing under it
    if (!entry.second.IsMap()) throw Error(source + ": section '" + name + "' must be a mapping of keys to values");
    for (const auto& item : entry.second) {
      const std::string key = item.first.as<std::string>();
      const Field* found = nullptr;
      for (const Field& f : table)
        if (f.section == name && f.key == key) found = &f;
      if (!found)
        throw Error(source + ": unknown key '" + name + "." + key +
                    "' (config/solvers.yaml lists every key with its default)");
      readField(*found, item.second, source);
    }
  }
}

}  // namespace

DemConfig demConfigForMethod(const std::string& method) {
  if (method == "grid") return DemConfig{};
  if (method == "mlp") return paperDemConfig();
  throw Error("unknown DEM method '" + method + "': use grid (the feature-grid DEM) or mlp (the paper's MLP DEM)");
}

SimulateOptions solverDefaults(const std::string& dem_method, const std::string& config_path) {
  SimulateOptions options;
  options.dem = demConfigForMethod(dem_method);
  return config_path.empty() ? options : loadSolverConfig(config_path, std::move(options));
}

SimulateOptions parseSolverConfig(const std::string& yaml_text, const std::string& source, SimulateOptions base) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw Error(source + ": not valid YAML: " + e.what());
  }
  if (!root || root.IsNull()) return base;
  if (!root.IsMap())
    throw Error(source + ": expected a mapping with sections dem, fem, pinn, voxel, control and the key mesher");
  const std::vector<Field> table = fields(base);
  try {
    readSections(root, table, source);
  } catch (const YAML::Exception& e) {
    throw Error(source + ": " + e.what());
  }
  return base;
}

SimulateOptions loadSolverConfig(const std::string& path, SimulateOptions base) {
  std::ifstream in(path);
  if (!in) throw Error("cannot read solver config '" + path + "'");
  std::stringstream text;
  text << in.rdbuf();
  return parseSolverConfig(text.str(), path, std::move(base));
}

std::string solverConfigYaml(const SimulateOptions& options) {
  SimulateOptions copy = options;
  std::ostringstream out;
  std::string section = "-";
  for (const Field& f : fields(copy)) {
    if (f.section != section) {
      section = f.section;
      out << "\n";
      if (!section.empty()) out << section << ":\n";
    }
    std::string line = (section.empty() ? "" : "  ") + f.key + ": " + f.write();
    line.resize(std::max<std::size_t>(line.size() + 1, 40), ' ');
    out << line << "# " << f.meaning << "\n";
  }
  return out.str();
}

std::vector<std::string> solverConfigKeys() {
  SimulateOptions scratch;
  std::vector<std::string> keys;
  for (const Field& f : fields(scratch)) keys.push_back(f.section.empty() ? f.key : f.section + "." + f.key);
  return keys;
}

}  // namespace demnerf::mechanics
