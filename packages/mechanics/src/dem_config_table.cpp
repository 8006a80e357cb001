// DemConfig's rows of the solver config table: one YAML section per part of the struct, so a file
// reads as the code does (dem: {grid: {cell: 0.015}} is config.grid.cell).

#include <limits>

#include "config_table.hpp"

namespace demnerf::mechanics::config_table {
namespace {

constexpr int kMany = std::numeric_limits<int>::max();

void append(std::vector<Field>& all, std::vector<Field> more) {
  for (Field& f : more) all.push_back(std::move(f));
}

std::vector<Field> networkFields(DemNetworkConfig& c) {
  const std::string s = "dem.network";
  return {integer(s, "width", c.width, 1, kMany, "hidden units per layer of the MLP"),
          integer(s, "depth", c.depth, 1, kMany, "hidden layers of the MLP"),
          choice(s, "activation", c.activation, words({"tanh", "sigmoid", "softplus", "sin"}), "MLP activation"),
          integer(s, "seed", c.seed, std::numeric_limits<int>::min(), kMany, "random seed"),
          flag(s, "double_precision", c.double_precision, "float64 instead of float32"),
          flag(s, "fused", c.fused, "the MLP alone's loss by the hand-written kernel instead of autograd"),
          number(s, "first_layer_scale", c.first_layer_scale, 0, true, kInf, "the first layer's initial weights x this"),
          flag(s, "thickness_inputs", c.thickness_inputs,
               "inputs normalised by the body's smallest half-extent on every axis, not each axis's own")};
}

std::vector<Field> trainingFields(DemConfig& c) {
  using B = DemConfig::Boundary;
  const std::string b = "dem.boundary", a = "dem.adam", n = "dem.output_newton", l = "dem.lbfgs",
                    gn = "dem.gauss_newton";
  return {
      choice<B>(b, "kind", c.boundary.kind, {{"exact", B::kExact}, {"penalty", B::kPenalty}},
                "fixtures held exactly, u = g + D z, or by the paper's penalty W_u MSE_u"),
      number(b, "penalty_weight", c.boundary.penalty_weight, 0, true, kInf, "W_u of the penalty boundary"),
      integer(a, "iterations", c.adam.iterations, 0, kMany, "Adam steps per load step (0: grid Newton only)"),
      number(a, "learning_rate", c.adam.learning_rate, 0, true, kInf, "Adam's initial learning rate"),
      number(a, "final_rate_ratio", c.adam.final_rate_ratio, 0, true, 1, "learning rate at a step's end / start"),
      integer(a, "rescale_every", c.adam.rescale_every, 0, kMany,
              "output amplitude line search every N Adam steps (0: never)"),
      integer(a, "rescale_until", c.adam.rescale_until, 0, kMany, "...during the first N Adam steps"),
      flag(a, "jitter", c.adam.jitter, "particles near fixtures/loads move within their cell every Adam step"),
      number(a, "jitter_band", c.adam.jitter_band, 0, false, kInf, "cells from a fixture that are jittered"),
      flag(n, "enabled", c.output_newton.enabled, "Newton on the MLP's output layer (exact boundary, no grid)"),
      integer(n, "every", c.output_newton.every, 0, kMany, "output-layer Newton every N Adam steps (0: only after)"),
      integer(n, "iterations", c.output_newton.iterations, 0, kMany, "output-layer Newton iterations"),
      integer(l, "iterations", c.lbfgs.iterations, 0, kMany, "L-BFGS polish per load step (0: off)"),
      integer(l, "sample_iterations", c.lbfgs.sample_iterations, 0, kMany,
              "L-BFGS iterations per jittered quadrature draw (0: one polish on the fixed particles)"),
      integer(l, "history", c.lbfgs.history, 1, kMany, "L-BFGS history length"),
      number(l, "max_energy_drop", c.lbfgs.max_energy_drop, 0, true, kInf,
             "reject a polish that lowers the energy more than this x |Pi|"),
      number(l, "max_growth", c.lbfgs.max_growth, 0, true, kInf, "reject a polish that grows max |u| more than this"),
      number(l, "tolerance", c.lbfgs.tolerance, 0, false, kInf, "L-BFGS stops when the loss changes less than this"),
      number(l, "cell_spacings", c.lbfgs.cell_spacings, 0, false, kInf,
             "sampled L-BFGS on Gauss points in cells of this many particle spacings (0: the particles)"),
      integer(l, "cell_boundary_levels", c.lbfgs.cell_boundary_levels, 0, 4,
              "times a cut cell of that quadrature is split 2 x 2 x 2 (0: the whole cell moment-fitted)"),
      integer(gn, "steps", c.gauss_newton.steps, 0, kMany,
              "most Gauss-Newton steps after the L-BFGS, MLP alone on the cell quadrature (0: off)"),
      number(gn, "tolerance", c.gauss_newton.tolerance, 0, false, kInf,
             "stop once the energy fell by less than this x |E| over the last `window` steps (0: no such stop)"),
      integer(gn, "window", c.gauss_newton.window, 1, kMany, "Gauss-Newton steps the energy's fall is measured over"),
      integer(gn, "sample", c.gauss_newton.sample, 1, kMany, "Gauss points the Gauss-Newton matrix is formed on"),
      number(gn, "damping", c.gauss_newton.damping, 0, true, kInf,
             "initial Levenberg-Marquardt damping, relative to the matrix's mean diagonal"),
      flag(gn, "spread", c.gauss_newton.spread,
           "draw the matrix's points systematically in proportion to their weights (false: uniformly)"),
      flag(gn, "current_tangent", c.gauss_newton.current_tangent,
           "form the matrix with the material's tangent at the current strain (false: at zero strain)"),
      number(gn, "recheck_tolerance", c.gauss_newton.recheck_tolerance, 0, false, kInf,
             "a converged answer the check refuses: the steps go on to this tolerance, then the check again (0: off)"),
  };
}

std::vector<Field> gridFields(DemGridConfig& c) {
  using Q = DemConfig::GridQuadrature;
  const std::string s = "dem.grid";
  return {
      number(s, "cell", c.cell, 0, false, kInf, "feature grid cell edge in m (0: from spacings or body_cells)"),
      number(s, "spacings", c.spacings, 0, false, kInf, "feature grid cell in particle spacings (0: from body_cells)"),
      number(s, "body_cells", c.body_cells, 0, false, kInf,
             "cells the body's volume holds, sizing the grid (0 with cell and spacings 0: MLP alone)"),
      number(s, "thickness_cells", c.thickness_cells, 0, false, kInf,
             "with body_cells: cells no finer than the mean thickness 4V/A over this many (0: off)"),
      number(s, "surface_cells", c.surface_cells, 0, false, kInf,
             "with body_cells: cells no finer than sqrt(A / this), about this many cells meet the surface (0: off)"),
      number(s, "rough_surface", c.rough_surface, 0, false, kInf,
             "with body_cells: a surface scattering about its local quadric by more than this share of two cells is rough (0: off)"),
      number(s, "rough_cell_ratio", c.rough_cell_ratio, 0, true, 1, "cell factor on a rough surface, in (0, 1]"),
      integer(s, "degree", c.degree, 1, 3, "B-spline degree of the feature grid"),
      choice<Q>(s, "quadrature", c.quadrature, {{"cells", Q::kCells}, {"particles", Q::kParticles}},
                "grid Newton quadrature: Gauss points in the cells inside the body, or the particles"),
      integer(s, "gauss_points", c.gauss_points, 1, 3, "Gauss points per axis and cell (cells quadrature)"),
      integer(s, "boundary_levels", c.boundary_levels, 0, 4,
              "times a cut cell is split 2x2x2 before moment fitting (cells quadrature)"),
      number(s, "extension_fill", c.extension_fill, 0, false, 1,
             "nodes touching no cell filled this much are extrapolated (extended B-splines; 0: off)"),
      integer(s, "newton_iterations", c.newton_iterations, 0, kMany, "Newton iterations of the grid solve"),
      integer(s, "nested_levels", c.nested_levels, 0, 4,
              "coarser grids whose Newton answers start the grid's Newton (cells quadrature; 0: off)"),
      number(s, "nested_ratio", c.nested_ratio, 1, true, kInf, "cell ratio between nested grid levels (> 1)"),
      flag(s, "projected_start", c.projected_start,
           "nested solve: the grid's first Newton step with strongly indefinite point tangents made semidefinite"),
      number(s, "refine_band", c.refine_band, 0, false, kInf,
             "cells near fixtures/loads whose particles are split 2x2x2 (particles quadrature)"),
      number(s, "surface_share", c.surface_share, 0, false, 1,
             "share of energyWeights() in the grid quadrature weights (particles quadrature)"),
  };
}

std::vector<Field> parametricFields(DemParametricConfig& c) {
  const std::string s = "dem.parametric";
  return {flag(s, "enabled", c.enabled, "train over load fractions [load_range_min, load_range_max] (MLP alone)"),
          number(s, "load_range_min", c.load_range_min, -kInf, false, kInf, "smallest load fraction"),
          number(s, "load_range_max", c.load_range_max, -kInf, false, kInf, "largest load fraction (>= 1)"),
          integer(s, "samples", c.samples, 1, kMany, "load fractions per Adam step")};
}

}  // namespace

std::vector<Field> demFields(DemConfig& c) {
  const std::string s = "dem";
  std::vector<Field> all{
      integer(s, "load_steps", c.load_steps, 0, kMany, "load steps (0: the scenario's, 1 with the grid)"),
      integer(s, "max_halvings", c.max_halvings, 0, kMany, "load-step halvings after a failed step"),
      integer(s, "threads", c.threads, 0, kMany,
              "threads (0: torch 1 below 50k particles, else all cores; the MLP's fused kernel 1 per 1000 points)"),
      flag(s, "surface_loads", c.surface_loads,
           "the MLP alone's loads spread over the surface, as the default DEM's (false: on the surface particles)"),
      flag(s, "tune_allocator", c.tune_allocator, "raise glibc's mmap threshold (reuses Adam's buffers)"),
      flag(s, "verbose", c.verbose, "print training details"),
  };
  append(all, networkFields(c.network));
  append(all, trainingFields(c));
  append(all, gridFields(c.grid));
  append(all, parametricFields(c.parametric));
  return all;
}

std::string renamedDemKey(const std::string& flat_key) {
  // The flat names of DemConfig before it was split into parts (RENAMES.txt of issue 15).
  static const std::vector<std::pair<std::string, std::string>> renames{
      {"width", "network.width"}, {"depth", "network.depth"}, {"activation", "network.activation"},
      {"seed", "network.seed"}, {"double_precision", "network.double_precision"}, {"boundary", "boundary.kind"},
      {"penalty_weight", "boundary.penalty_weight"}, {"adam_iterations", "adam.iterations"},
      {"adam_learning_rate", "adam.learning_rate"}, {"adam_final_rate_ratio", "adam.final_rate_ratio"},
      {"rescale_every", "adam.rescale_every"}, {"rescale_until", "adam.rescale_until"}, {"jitter", "adam.jitter"},
      {"jitter_band", "adam.jitter_band"}, {"output_newton", "output_newton.enabled"},
      {"newton_every", "output_newton.every"}, {"newton_iterations", "output_newton.iterations"},
      {"lbfgs_iterations", "lbfgs.iterations"}, {"lbfgs_history", "lbfgs.history"},
      {"polish_max_energy_drop", "lbfgs.max_energy_drop"}, {"polish_max_growth", "lbfgs.max_growth"},
      {"tolerance", "lbfgs.tolerance"}, {"grid_cell", "grid.cell"}, {"grid_spacings", "grid.spacings"},
      {"grid_body_cells", "grid.body_cells"}, {"grid_degree", "grid.degree"}, {"grid_quadrature", "grid.quadrature"},
      {"grid_gauss_points", "grid.gauss_points"}, {"grid_boundary_levels", "grid.boundary_levels"},
      {"grid_extension_fill", "grid.extension_fill"}, {"grid_newton_iterations", "grid.newton_iterations"},
      {"grid_refine_band", "grid.refine_band"}, {"grid_surface_share", "grid.surface_share"},
      {"parametric", "parametric.enabled"}, {"load_range_min", "parametric.load_range_min"},
      {"load_range_max", "parametric.load_range_max"}, {"parametric_samples", "parametric.samples"}};
  for (const auto& [flat, nested] : renames)
    if (flat == flat_key) return nested;
  return "";
}

}  // namespace demnerf::mechanics::config_table
