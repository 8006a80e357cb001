// The paper's DEM network (`--method mlp`) rebuilt in double with autograd, for the benches that
// study it apart from the product's float32 kernel: mechanics_mlp_fit (what it can represent) and
// mechanics_mlp_gn (a Gauss-Newton optimiser of its energy). One matrix cloud with its reference,
// the MLP's cell quadrature with the Dirichlet lift, the potential computed independently, and the
// hand-over of a field to the product's DEM (its equilibrium check, further training).
#pragma once

#include <torch/torch.h>

#include <map>
#include <string>
#include <utility>
#include <vector>

#include "demnerf/core/scenario.hpp"
#include "demnerf/mechanics/cell_quadrature.hpp"
#include "demnerf/mechanics/dem_solver.hpp"
#include "demnerf/mechanics/held_face.hpp"

namespace demnerf::bench::mlp {

namespace dm = demnerf::mechanics;
namespace core = demnerf::core;
using Eigen::Vector3d;
using torch::Tensor;
using Arguments = std::map<std::string, std::string>;

std::string text(const Arguments& a, const char* key, const std::string& fallback);
Tensor rows(const std::vector<Vector3d>& v);
Tensor matrices(const std::vector<Eigen::Matrix3d>& v);
double relL2(const Tensor& u, const Tensor& ref);
Tensor green(const Tensor& du);

// The DEM network in double: z = W_L tanh(...tanh(W_0 (X - c) / h + b_0)...) + b_L.
struct Net {
  std::vector<Tensor> W, b;
  Tensor center, inv_half;
  Tensor z(const Tensor& x) const {
    Tensor h = (x - center) * inv_half;
    for (std::size_t l = 0; l + 1 < W.size(); ++l) h = torch::tanh(torch::addmm(b[l], h, W[l].t()));
    return torch::addmm(b.back(), h, W.back().t());
  }
  // z and its X-gradient [n, i, k] = dz_i / dX_k, forward mode.
  std::pair<Tensor, Tensor> withGradient(const Tensor& x) const {
    Tensor h = (x - center) * inv_half;
    Tensor dh = torch::diag(inv_half.squeeze(0)).unsqueeze(0).expand({x.size(0), 3, 3});  // [n, k, in]
    for (std::size_t l = 0; l + 1 < W.size(); ++l) {
      h = torch::tanh(torch::addmm(b[l], h, W[l].t()));
      dh = (1 - h * h).unsqueeze(1) * torch::matmul(dh, W[l].t());
    }
    return {torch::addmm(b.back(), h, W.back().t()), torch::matmul(dh, W.back().t()).transpose(1, 2)};
  }
  std::vector<Tensor> parameters() const {
    std::vector<Tensor> p;
    for (std::size_t l = 0; l < W.size(); ++l) p.push_back(W[l]), p.push_back(b[l]);
    return p;
  }
  void set(const dm::DemState& st) {
    torch::NoGradGuard guard;
    for (std::size_t l = 0; l < st.weights.size(); ++l) {
      const Eigen::MatrixXd Wt = st.weights[l].transpose();  // column-major: its buffer is W row-major
      const Tensor w = torch::from_blob(const_cast<double*>(Wt.data()), {st.weights[l].rows(), st.weights[l].cols()},
                                        torch::kFloat64);
      const Tensor bias = torch::from_blob(const_cast<double*>(st.biases[l].data()), {st.biases[l].size()}, torch::kFloat64);
      if (W.size() <= l) W.push_back(w.clone().requires_grad_(true)), b.push_back(bias.clone().requires_grad_(true));
      else W[l].copy_(w), b[l].copy_(bias);
    }
  }
  void into(dm::DemState& st) const {
    for (std::size_t l = 0; l < W.size(); ++l) {
      const Tensor w = W[l].detach().contiguous(), bias = b[l].detach().contiguous();
      st.weights[l] = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
          w.data_ptr<double>(), w.size(0), w.size(1));
      st.biases[l] = Eigen::Map<const Eigen::VectorXd>(bias.data_ptr<double>(), bias.size(0));
    }
  }
};

// One matrix cloud with its reference and the solver's view of it (box, lift at the particles).
struct Setup {
  Arguments a;
  std::string name;
  core::Scenario scenario;
  core::ParticleCloud cloud;
  Tensor ref, x, g, D;
  Vector3d lo, hi;
  double length = 1.0, s = 1.0;  // s: the output scale of the fit, max |u_ref|
  std::vector<dm::HeldFace> held;
};

/// Samples the cloud, reads its reference and builds the lift at the particles.
Setup setUp(const Arguments& a);

// The MLP's cell quadrature as cellDraw() builds it (2 Gauss points per axis, cut cells
// moment-fitted whole), with the lift there.
struct Quadrature {
  dm::CellQuadrature q;
  Tensor x, w, g, D, grad_g, grad_D;  // w normalised to sum 1
  Tensor du(const Net& net, double s) const {
    const auto [z, dz] = net.withGradient(x);
    return grad_g + grad_D * (s * z).unsqueeze(2) + D.unsqueeze(2) * s * dz;
  }
};

Quadrature mlpQuadrature(const Setup& su);

// Strain energy on the quadrature (compressible Neo-Hookean, as the DEM's kernel) and the work
// of the particle loads on u at the particles: the DEM's potential, computed independently.
void printEnergy(const char* what, const Setup& su, const Quadrature& qu, const Tensor& du, const Tensor& u_particles);

// The fitted field as the DEM's state: its check, and the DEM's training from it.
void demFromFit(const Setup& su, const Net& net, dm::DemState st, double s, double cpu0);

}  // namespace demnerf::bench::mlp
