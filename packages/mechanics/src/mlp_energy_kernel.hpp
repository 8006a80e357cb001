#pragma once
// The MLP-only DEM's loss and its parameter gradient in one pass (issue 13, item 6): the potential
// energy of u = s g + D o (A z(X)) on a quadrature, z a tanh MLP, with the network's X-derivatives
// carried forward and everything run backward by hand. Autograd spent ~4 us a point on the graph
// of ~60 small tensor operations (T-bar at 1/10: 106 ms CPU an L-BFGS evaluation); here the
// points run 16 to a vector register through the layers, the per-point mechanics in double.
// Private to packages/mechanics/src. No Eigen or torch types: this translation unit may be built
// for the machine's own instruction set (DEMNERF_MECHANICS_NATIVE) without changing any ABI.

#include <cstdint>
#include <vector>

namespace demnerf::mechanics::mlp_kernel {

/// A tanh MLP 3 -> width x depth -> 3, weights row-major (out x in), float32, inputs normalised
/// as (X - center) * inv_half.
struct Network {
  int width = 0, depth = 0;
  std::vector<const float*> weights, biases;  ///< depth + 1 layers
  float center[3] = {0, 0, 0}, inv_half[3] = {1, 1, 1};
};

/// Where the parameter gradient goes (same shapes as Network's), overwritten.
struct Gradient {
  std::vector<float*> weights, biases;
};

/// Volume quadrature: n points with the lift (g [n,3], grad_g [n,3,3] (i, k) = d g_i / dX_k,
/// D [n,3], grad_D [n,3,3]), weights [n] and body forces already times the weight [n,3].
/// lift pointers null: the penalty boundary's plain u = A z.
struct VolumePoints {
  std::int64_t n = 0;
  const float *x = nullptr, *weight = nullptr, *body = nullptr;
  const float *g = nullptr, *grad_g = nullptr, *D = nullptr, *grad_D = nullptr;
};

/// Point loads (traction x area at surface points), with the lift's g and D there (null: none).
struct LoadPoints {
  std::int64_t n = 0;
  const float *x = nullptr, *force = nullptr, *g = nullptr, *D = nullptr;
};

/// The penalty boundary's points: W_u * mean_c |(A z - s v) o mask|^2 / A^2.
struct PenaltyPoints {
  std::int64_t n = 0;
  const float *x = nullptr, *value = nullptr, *mask = nullptr;
  double weight = 0.0;
};

struct Problem {
  double mu = 0.0, lambda = 0.0;  ///< the compressible Neo-Hookean's Lame constants
  /// The decoupled Neo-Hookean instead (Cook's membrane): kappa/4 (J^2 - 1 - 2 ln J) + mu/2 (J^(-2/3) I1 - 3).
  bool decoupled = false;
  double kappa = 0.0;
  double load_scale = 1.0;        ///< s
  double output_scale = 1.0;      ///< A (m)
  double energy_scale = 1.0;      ///< the loss is Pi / energy_scale (+ penalty)
  VolumePoints volume;
  LoadPoints loads;
  PenaltyPoints penalty;
};

struct Result {
  double loss = 0.0;    ///< Pi / energy_scale + penalty
  double energy = 0.0;  ///< Pi (J)
  double min_J = 0.0;   ///< smallest det F over the volume points
  bool admissible = false;  ///< finite and det F > 0 everywhere (else no gradient is written)
};

/// The loss and (when `gradient` is given) its gradient in every weight and bias. `threads` > 1
/// splits the points into contiguous ranges, each with its own accumulators.
Result energyAndGradient(const Network& net, const Problem& problem, const Gradient* gradient, int threads = 1);

}  // namespace demnerf::mechanics::mlp_kernel
