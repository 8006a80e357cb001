#pragma once
// What the two network solvers (dem_solver.cpp, pinn_solver.cpp) share: Eigen <-> tensor
// conversion, the Neo-Hookean energy density on batches, parameter snapshots, and the two
// process settings that make small-batch training fast on a loaded CPU. Private to
// packages/mechanics/src: only the torch translation units include it.

#include <torch/torch.h>


#include <Eigen/Core>
#include <algorithm>
#include <limits>
#include <string>
#include <thread>
#include <vector>

#include "demnerf/core/ply.hpp"
#include "demnerf/mechanics/process_settings.hpp"

#include "demnerf/mechanics/material.hpp"

namespace demnerf::mechanics::torch_support {

using torch::Tensor;

/// Rows of 3 (vectors) or 3x3 (matrices) or scalars, converted in double then cast to dtype.
inline Tensor toTensor(const std::vector<Eigen::Vector3d>& v, torch::Dtype dtype) {
  Tensor t = torch::empty({static_cast<long>(v.size()), 3}, torch::kFloat64);
  double* p = t.data_ptr<double>();
  for (std::size_t i = 0; i < v.size(); ++i)
    for (int c = 0; c < 3; ++c) p[3 * i + c] = v[i](c);
  return t.to(dtype);
}

inline Tensor toTensor(const std::vector<Eigen::Matrix3d>& v, torch::Dtype dtype) {
  Tensor t = torch::empty({static_cast<long>(v.size()), 3, 3}, torch::kFloat64);
  double* p = t.data_ptr<double>();
  for (std::size_t i = 0; i < v.size(); ++i)
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) p[9 * i + 3 * r + c] = v[i](r, c);
  return t.to(dtype);
}

inline Tensor toTensor(const std::vector<double>& v, torch::Dtype dtype) {
  Tensor t = torch::empty({static_cast<long>(v.size())}, torch::kFloat64);
  std::copy(v.begin(), v.end(), t.data_ptr<double>());
  return t.to(dtype);
}

inline std::vector<Eigen::Vector3d> toVectors(const Tensor& t) {
  const Tensor d = t.to(torch::kFloat64).contiguous();
  const double* p = d.data_ptr<double>();
  std::vector<Eigen::Vector3d> out(static_cast<std::size_t>(d.size(0)));
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = Eigen::Vector3d(p[3 * i], p[3 * i + 1], p[3 * i + 2]);
  return out;
}

/// The inverse of toTensor(vector<Matrix3d>): an (n, 3, 3) tensor as row-major 3x3 matrices.
inline std::vector<Eigen::Matrix3d> toMatrices(const Tensor& t) {
  const Tensor d = t.to(torch::kFloat64).contiguous();
  const double* p = d.data_ptr<double>();
  std::vector<Eigen::Matrix3d> out(static_cast<std::size_t>(d.size(0)));
  for (std::size_t i = 0; i < out.size(); ++i)
    out[i] = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(p + 9 * i);
  return out;
}

/// Psi per point from det F and tr(F^T F), for the material's model (the paper's compressible
/// Neo-Hookean or the decoupled form of the Cook's membrane reference).
inline Tensor neoHookeanEnergyDensity(const Tensor& J, const Tensor& I1, const HyperelasticMaterial& material,
                                      const std::string& model) {
  const Tensor lnJ = torch::log(J);
  const double mu = material.mu();
  if (model == "neo_hookean_decoupled")
    return 0.25 * material.kappa() * (J * J - 1 - 2 * lnJ) + 0.5 * mu * (torch::pow(J, -2.0 / 3.0) * I1 - 3);
  return 0.5 * mu * (I1 - 3) - mu * lnJ + 0.5 * material.lambda() * lnJ * lnJ;
}

inline std::vector<Tensor> snapshot(const std::vector<Tensor>& parameters) {
  std::vector<Tensor> s;
  for (const Tensor& p : parameters) s.push_back(p.detach().clone());
  return s;
}

inline void restore(const std::vector<Tensor>& parameters, const std::vector<Tensor>& saved) {
  torch::NoGradGuard guard;
  for (std::size_t i = 0; i < parameters.size(); ++i) parameters[i].copy_(saved[i]);
}

/// Von Mises stress per point from displacement gradients [n, i, k] (NaN where det F <= 0).
inline std::vector<double> vonMisesFromGradients(const Tensor& grad_u, const HyperelasticMaterial& material) {
  const Tensor gu = grad_u.to(torch::kFloat64).contiguous();
  const double* g = gu.data_ptr<double>();
  std::vector<double> out(static_cast<std::size_t>(gu.size(0)));
  for (std::size_t i = 0; i < out.size(); ++i) {
    Eigen::Matrix3d F = Eigen::Matrix3d::Identity();
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) F(a, b) += g[9 * i + 3 * a + b];
    out[i] = F.determinant() > 0 ? vonMises(cauchyStress(F, material.stress(F)))
                                 : std::numeric_limits<double>::quiet_NaN();
  }
  return out;
}

/// The particles' bounding box as the networks see it: the centre, the half extents (never 0, so
/// a flat cloud still normalises) and the largest extent, the body's length scale.
struct BodyBox {
  Eigen::Vector3d center, half;
  double length = 1.0;
};
inline BodyBox bodyBox(const core::ParticleCloud& cloud) {
  Eigen::Vector3d lo = cloud.positions[0], hi = lo;
  for (const auto& p : cloud.positions) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  return {0.5 * (lo + hi), (0.5 * (hi - lo)).cwiseMax(1e-9 * (hi - lo).norm() + 1e-12), (hi - lo).maxCoeff()};
}

/// Every core of the machine (at least one).
inline int allCores() { return static_cast<int>(std::max(1u, std::thread::hardware_concurrency())); }

/// Torch and BLAS threads for a solve, set on the solving thread when it starts (not in a
/// constructor): `threads` when > 0, else one thread below 50k particles (fastest for
/// product-size clouds on shared 2-core machines) and every core above, where the threads'
/// synchronisation pays off. The process's own count is dem_nerf::configureRuntime's.
inline void setSolverThreads(int threads, std::size_t particles) {
  const int n = threads > 0 ? threads : particles < 50000 ? 1 : allCores();
  at::set_num_threads(n);
  mechanics::setBlasThreads(n);
}

}  // namespace demnerf::mechanics::torch_support
