// A DemSolver as data (what dem_model_io saves) and back.
#include <torch/torch.h>

#include "demnerf/core/error.hpp"
#include "dem_solver_impl.hpp"

namespace demnerf::mechanics {

DemState DemSolver::state() const {
  const Impl& m = *impl_;
  const std::vector<torch::Tensor>& weights = m.net.weights();
  const std::vector<torch::Tensor>& biases = m.net.biases();
  DemState st;
  st.config = m.config;
  st.scenario = m.scenario;
  st.cloud = m.cloud;
  st.output_scale = m.out_scale;
  st.energy_scale = m.energy_scale;
  st.fraction = m.fraction;
  st.rescaled = m.rescaled;
  for (std::size_t l = 0; l < weights.size(); ++l) {
    st.weights.push_back(toEigen(weights[l].detach()));
    st.biases.push_back(toEigen(biases[l].detach().unsqueeze(1)).col(0));
  }
  if (m.grid) st.grid_coefficients = toEigen(m.grid_coef.detach());
  return st;
}

DemSolver DemSolver::fromState(const DemState& state) {
  DemSolver solver(state.cloud, state.scenario, state.config);
  Impl& m = *solver.impl_;
  std::vector<torch::Tensor>& weights = m.net.weights();
  std::vector<torch::Tensor>& biases = m.net.biases();
  if (state.weights.size() != weights.size() || state.biases.size() != biases.size())
    throw core::Error("DEM state has " + std::to_string(state.weights.size()) + " layers; the config (depth " +
                      std::to_string(state.config.network.depth) + ") needs " + std::to_string(weights.size()));
  torch::NoGradGuard guard;
  for (std::size_t l = 0; l < weights.size(); ++l) {
    const Eigen::MatrixXd& W = state.weights[l];
    const Eigen::VectorXd& b = state.biases[l];
    if (W.rows() != weights[l].size(0) || W.cols() != weights[l].size(1) || b.size() != biases[l].size(0))
      throw core::Error("DEM state: layer " + std::to_string(l) + " is " + std::to_string(W.rows()) + " x " +
                        std::to_string(W.cols()) + ", the config needs " + std::to_string(weights[l].size(0)) +
                        " x " + std::to_string(weights[l].size(1)));
    if (!W.allFinite() || !b.allFinite()) throw core::Error("DEM state: layer " + std::to_string(l) + " holds NaN or inf");
    // Eigen is column-major: its transpose's buffer is the row-major (out x in) tensor.
    const Eigen::MatrixXd Wt = W.transpose();
    weights[l].copy_(torch::from_blob(const_cast<double*>(Wt.data()), {W.rows(), W.cols()}, torch::kFloat64));
    biases[l].copy_(torch::from_blob(const_cast<double*>(b.data()), {b.size()}, torch::kFloat64));
  }
  if (m.grid) {
    const Eigen::MatrixXd& C = state.grid_coefficients;
    if (C.rows() != m.grid->nodeCount() || C.cols() != 3 || !C.allFinite())
      throw core::Error("DEM state: the feature grid needs " + std::to_string(m.grid->nodeCount()) +
                        " x 3 finite coefficients, the state has " + std::to_string(C.rows()) + " x " +
                        std::to_string(C.cols()));
    m.setGridCoefficients(C);
  }
  if (!(state.output_scale > 0) || !(state.energy_scale > 0) || !std::isfinite(state.fraction))
    throw core::Error("DEM state: output and energy scales must be positive and the load fraction finite");
  m.out_scale = state.output_scale;
  m.energy_scale = state.energy_scale;
  m.fraction = state.fraction;
  m.rescaled = state.rescaled;
  return solver;
}

}  // namespace demnerf::mechanics
