#pragma once
// Newton's method on the last (linear) layer of the DEM network, with the hidden layers frozen.
//
// With the exact Dirichlet construction u = s g(X) + D(X) * c W h(X) (h: the last hidden layer's
// activations plus a constant 1, W: the output layer's weights and bias, c: the output scale), the
// displacement and its gradient are linear in W. The potential energy restricted to W is then a
// small smooth problem (3 x (width + 1) unknowns) whose gradient and Hessian follow from the
// material's stress and tangent: a Ritz-Galerkin solve in the network's own basis. Adam is slow
// on soft, large-amplitude modes (torsion: the amplitude grows ~100x from the a-priori scale);
// Newton finds the best amplitude and shape in the current basis in a few iterations, and Adam is
// left to improve the basis. Eigen only: no torch in this file.

#include <Eigen/Core>

#include "demnerf/mechanics/material.hpp"

namespace demnerf::mechanics {

/// The quadrature points of the energy and the loaded surface, described in the network's basis.
/// M = features + 1 (the trailing constant for the bias). Rows of vector fields are points.
struct OutputLayerProblem {
  Eigen::MatrixXd h;            ///< n x M: last hidden activations, last column 1
  Eigen::MatrixXd dh;           ///< 3n x M: d h / d X_k at point p in row 3 p + k (last column 0)
  Eigen::MatrixXd g, D;         ///< n x 3: lift and distance factor per component
  Eigen::MatrixXd grad_g;       ///< n x 9: d g_i / d X_k at column 3 i + k
  Eigen::MatrixXd grad_D;       ///< n x 9: d D_i / d X_k at column 3 i + k
  Eigen::VectorXd volume;       ///< n: quadrature weights (m^3)
  Eigen::MatrixXd body;         ///< n x 3: body force times volume (N)
  Eigen::MatrixXd surface_h;    ///< s x M: features at the loaded surface points
  Eigen::MatrixXd surface_g, surface_D;  ///< s x 3
  Eigen::MatrixXd traction_area;         ///< s x 3: traction times area (N)
  double output_scale = 1.0;    ///< c (m)
  double load_scale = 1.0;      ///< s: load fraction (loads and prescribed displacements)
};

struct OutputLayerNewtonConfig {
  int max_iterations = 12;
  /// Stops when the Newton decrement (the predicted energy drop) is below this fraction of
  /// max(|Pi|, strain energy).
  double tolerance = 1e-10;
  /// Tikhonov shift, relative to the Hessian's mean diagonal, added when the Hessian is not
  /// positive definite (far from the minimum of a nonconvex energy), multiplied by 10 until it is.
  double initial_shift = 1e-8;
};

struct OutputLayerNewtonOutcome {
  double energy = 0.0;   ///< potential energy at the returned W (J)
  double min_J = 0.0;
  int iterations = 0;
  bool converged = false;
};

/// Minimises the potential energy over W (3 x M, the output layer's weights with the bias as the
/// last column), starting from W; W is only ever replaced by states with lower energy and every
/// det F > 0 (a backtracking line search rejects inverted states), so the result is never worse
/// than the start.
OutputLayerNewtonOutcome minimiseOutputLayer(const OutputLayerProblem& problem, const HyperelasticMaterial& material,
                                             Eigen::MatrixXd& W, const OutputLayerNewtonConfig& config = {});

}  // namespace demnerf::mechanics
