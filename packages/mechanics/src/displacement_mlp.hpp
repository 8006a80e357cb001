#pragma once
// The displacement network of both network solvers (dem_solver, pinn_solver): an MLP from
// normalised coordinates (plus, in the DEM's parametric mode, the load fraction) to a 3-vector,
// with its derivatives in X to second order. Private to packages/mechanics/src.

#include <Eigen/Core>
#include <string>
#include <vector>

#include "torch_solver_support.hpp"

namespace demnerf::mechanics {

/// z(X) [n, 3] with dz [n, k, i] = dz_i / dX_k (order >= 1) and d2z [n, p, i] = d2z_i / dX_k dX_m
/// for the six pairs p = (k <= m) in kHessianPairs order (order 2). The derivatives are propagated
/// forward through the layers: one extra matmul per derivative slot, differentiable for the
/// parameter gradient, where nested reverse passes would cost three backward graphs.
class DisplacementMlp {
 public:
  struct Output {
    torch::Tensor value, d1, d2;
  };
  /// (k, m) of the six symmetric Hessian slots, and the slot of each (k, m) row-major.
  static const long kPairK[6], kPairM[6], kSlotOf[9];

  DisplacementMlp() = default;
  /// Inputs X normalised to [-1, 1] over the box center +- half; `extra_inputs` further inputs
  /// (not normalised, no derivatives). Hidden layers Glorot-uniform from torch's generator, the
  /// output layer zero so training starts from the rest state (or the Dirichlet lift); the first
  /// layer's bound times first_layer_scale.
  DisplacementMlp(int extra_inputs, int width, int depth, const std::string& activation,
                  const Eigen::Vector3d& center, const Eigen::Vector3d& half, torch::Dtype dtype,
                  double first_layer_scale = 1.0);

  /// Activations of the last hidden layer (value [n, width], d1 [n, 3, width], d2 [n, 6, width]).
  /// `extra` is [n, extra_inputs] or undefined when there are none.
  Output hidden(const torch::Tensor& x, const torch::Tensor& extra, int order) const;
  /// The network's output (the last layer applied to hidden()).
  Output forward(const torch::Tensor& x, const torch::Tensor& extra, int order) const;
  Output forward(const torch::Tensor& x, int order) const { return forward(x, torch::Tensor(), order); }

  std::vector<torch::Tensor> parameters() const;
  /// The input normalisation: X -> (X - center) * inv_half, both [1, 3] / [3] in the dtype.
  const torch::Tensor& center() const { return center_; }
  const torch::Tensor& invHalf() const { return inv_half_; }
  std::vector<torch::Tensor>& weights() { return weights_; }  ///< row-major out x in
  std::vector<torch::Tensor>& biases() { return biases_; }
  const std::vector<torch::Tensor>& weights() const { return weights_; }
  const std::vector<torch::Tensor>& biases() const { return biases_; }

 private:
  // sigma(a) and its first two derivatives (s2 only when asked).
  void activate(const torch::Tensor& a, torch::Tensor& h, torch::Tensor& s1, torch::Tensor* s2) const;

  std::string activation_;
  torch::Tensor center_, inv_half_, pair_k_, pair_m_;
  std::vector<torch::Tensor> weights_, biases_;
};

}  // namespace demnerf::mechanics
