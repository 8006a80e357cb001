#pragma once
// The optimisers of the network solvers (dem_solver, pinn_solver): Adam whose rate decays
// exponentially over a run, and an L-BFGS run that steps around inadmissible points. Private to
// packages/mechanics/src.

#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace demnerf::mechanics {

/// Adam over `iterations` steps with the rate decaying geometrically from `rate` to
/// rate * final_ratio: large early steps find the field's shape, small late ones settle it.
class DecayingAdam {
 public:
  DecayingAdam(const std::vector<torch::Tensor>& parameters, double rate, double final_ratio, int iterations)
      : adam_(parameters, torch::optim::AdamOptions(rate)),
        rate_(rate),
        decay_(std::pow(std::max(final_ratio, 1e-6), 1.0 / std::max(1, iterations - 1))) {}

  void zeroGrad() { adam_.zero_grad(); }
  /// One Adam step with the current rate, then the rate decays.
  void step() {
    adam_.step();
    rate_ *= decay_;
    for (auto& group : adam_.param_groups()) static_cast<torch::optim::AdamOptions&>(group.options()).lr(rate_);
  }

 private:
  torch::optim::Adam adam_;
  double rate_, decay_;
};

/// L-BFGS with a strong-Wolfe line search, `iterations` iterations (a quarter more evaluations) a
/// step() call, stopping when the loss changes less than `tolerance_change`.
inline torch::optim::LBFGSOptions lbfgsOptions(int iterations, int history, double tolerance_change) {
  return torch::optim::LBFGSOptions(1.0)
      .max_iter(iterations)
      .max_eval(iterations * 5 / 4)
      .history_size(history)
      .tolerance_grad(1e-12)
      .tolerance_change(tolerance_change)
      .line_search_fn("strong_wolfe");
}

/// evaluate() as the closure of lbfgs.step: an inadmissible point is 1e30 without a gradient. A
/// loss without a graph has set the parameters' gradients itself (the DEM's fused kernel).
template <typename Evaluate>
torch::Tensor lbfgsClosure(torch::optim::LBFGS& lbfgs, Evaluate& evaluate) {
  lbfgs.zero_grad();
  auto [loss, admissible] = evaluate();
  if (!admissible) return torch::full({}, 1e30, loss.options());
  if (loss.requires_grad()) loss.backward();
  return loss;
}

/// L-BFGS on a loss whose quadrature is redrawn: `iterations` in all, `resample()` before every
/// run of `per_draw` of them. One history across the draws: the draws differ by quadrature noise,
/// and the curvature they share is the field's.
template <typename Evaluate, typename Resample>
void runSampledLbfgs(const std::vector<torch::Tensor>& parameters, int iterations, int per_draw, int history,
                     double tolerance_change, Evaluate&& evaluate, Resample&& resample) {
  torch::optim::LBFGS lbfgs(parameters, lbfgsOptions(std::max(1, per_draw), history, tolerance_change));
  for (int done = 0; done < iterations; done += std::max(1, per_draw)) {
    resample();
    lbfgs.step([&]() -> torch::Tensor { return lbfgsClosure(lbfgs, evaluate); });
  }
}

/// One L-BFGS run with a strong-Wolfe line search, `iterations` iterations (a quarter more
/// evaluations) and the given history, stopping when the loss changes less than
/// `tolerance_change`. `evaluate()` gives the loss and whether the point is admissible (finite,
/// no inverted particle); an inadmissible trial point is reported as 1e30 without a gradient, so
/// the line search rejects it without it entering the curvature history.
template <typename Evaluate>
void runLbfgs(const std::vector<torch::Tensor>& parameters, int iterations, int history, double tolerance_change,
              Evaluate&& evaluate) {
  torch::optim::LBFGS lbfgs(parameters, lbfgsOptions(iterations, history, tolerance_change));
  lbfgs.step([&]() -> torch::Tensor { return lbfgsClosure(lbfgs, evaluate); });
}

}  // namespace demnerf::mechanics
