#include "pinn_config_check.hpp"

#include <cmath>
#include <sstream>
#include <string>
#include <utility>

#include "demnerf/core/error.hpp"

namespace demnerf::mechanics {

void checkPinnConfig(const PinnConfig& config) {
  auto bad = [](const std::string& what, double v) {
    std::ostringstream msg;
    msg << "PINN config: " << what << " = " << v;
    return core::Error(msg.str());
  };
  if (config.width < 1 || config.depth < 1)
    throw core::Error("PINN network needs width >= 1 and depth >= 1, got width " + std::to_string(config.width) +
                      ", depth " + std::to_string(config.depth));
  if (config.activation != "tanh" && config.activation != "sin" && config.activation != "softplus")
    throw core::Error("unknown PINN activation '" + config.activation +
                      "': use tanh, sin or softplus (the residual needs second derivatives)");
  const std::pair<const char*, double> weights[] = {{"weight_residual (W_R)", config.weight_residual},
                                                    {"weight_traction (W_t)", config.weight_traction},
                                                    {"weight_displacement (W_u)", config.weight_displacement}};
  for (const auto& [name, w] : weights)
    if (!std::isfinite(w) || w < 0) throw bad(std::string(name) + " must be finite and >= 0", w);
  if (!(config.weight_residual + config.weight_traction + config.weight_displacement > 0))
    throw core::Error("PINN config: all loss weights are 0, nothing to train");
  if (config.adam_iterations < 0 || config.lbfgs_iterations < 0 || config.adam_iterations + config.lbfgs_iterations == 0)
    throw core::Error("PINN config: adam_iterations and lbfgs_iterations must be >= 0 and not both 0, got " +
                      std::to_string(config.adam_iterations) + " and " + std::to_string(config.lbfgs_iterations));
  if (!std::isfinite(config.adam_learning_rate) || !(config.adam_learning_rate > 0))
    throw bad("adam_learning_rate must be > 0", config.adam_learning_rate);
  if (!std::isfinite(config.adam_final_rate_ratio) || !(config.adam_final_rate_ratio > 0) ||
      config.adam_final_rate_ratio > 1)
    throw bad("adam_final_rate_ratio must be in (0, 1]", config.adam_final_rate_ratio);
  if (config.load_steps < 0) throw bad("load_steps must be >= 0 (0: the scenario's)", config.load_steps);
  if (config.lbfgs_history < 1) throw bad("lbfgs_history must be >= 1", config.lbfgs_history);
  if (!std::isfinite(config.displacement_scale) || config.displacement_scale < 0)
    throw bad("displacement_scale must be finite and >= 0 (0: estimated)", config.displacement_scale);
  if (config.residual_batch < 0) throw bad("residual_batch must be >= 0 (0: all)", config.residual_batch);
}

}  // namespace demnerf::mechanics
