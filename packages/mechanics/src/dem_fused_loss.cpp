// The MLP-only DEM's loss through the hand-written kernel (mlp_energy_kernel.hpp) instead of
// autograd: the same energy on the same points, its parameter gradient written into the
// parameters' .grad, for the L-BFGS that trains `--method mlp`.
#include <torch/torch.h>

#include <algorithm>
#include <cstdint>
#include <iostream>

#include "demnerf/mechanics/cell_quadrature.hpp"
#include "dem_config_check.hpp"
#include "dem_solver_impl.hpp"
#include "mlp_energy_kernel.hpp"

namespace demnerf::mechanics {

using torch::Tensor;
using torch_support::toTensor;

namespace {

const float* floats(const Tensor& t) { return t.defined() && t.numel() > 0 ? t.data_ptr<float>() : nullptr; }

// The kernel splits its points over threads itself, each with its own accumulators, so unlike
// torch's small operations (one thread below 50k particles, setSolverThreads) a few thousand
// points already keep two cores busy: Beam3D at 1/10 (~3k points) on the quiet 2-core machine
// trains in 8-9 s on two threads against 11-12 s on one. DemConfig::threads > 0 still decides.
int kernelThreads(int configured, std::int64_t points) {
  if (configured > 0) return configured;
  constexpr std::int64_t kPointsPerThread = 1000;
  return static_cast<int>(std::clamp<std::int64_t>(points / kPointsPerThread, 1, torch_support::allCores()));
}

}  // namespace

// What the kernel computes: the MLP alone (no feature grid, no load input) in float32 with tanh,
// on the compressible or the decoupled Neo-Hookean. Anything else keeps autograd.
bool DemSolver::Impl::fusedLossAvailable() const {
  return config.network.fused && !grid && !config.parametric.enabled && dtype == torch::kFloat32 &&
         config.network.activation == "tanh" &&
         (scenario.material.model == "neo_hookean" || scenario.material.model == "neo_hookean_decoupled") &&
         config.network.depth >= 1;
}

mlp_kernel::Network DemSolver::Impl::kernelNetwork() const {
  mlp_kernel::Network nn;
  nn.width = config.network.width;
  nn.depth = config.network.depth;
  for (std::size_t l = 0; l < net.weights().size(); ++l) {
    nn.weights.push_back(net.weights()[l].data_ptr<float>());
    nn.biases.push_back(net.biases()[l].data_ptr<float>());
  }
  const Tensor center = net.center().contiguous(), inv_half = net.invHalf().contiguous();
  for (int k = 0; k < 3; ++k) {
    nn.center[k] = center.data_ptr<float>()[k];
    nn.inv_half[k] = inv_half.data_ptr<float>()[k];
  }
  return nn;
}

// The loss on a draw (drawJitter()) and, with `gradient`, its gradient into the parameters' .grad.
// Returns the loss (no graph), sets energy and min det F; an inadmissible point gives a NaN loss.
Tensor DemSolver::Impl::fusedLoss(double scale, const JitterDraw& draw, bool gradient, double* energy,
                                  double* min_J) {
  const mlp_kernel::Network nn = kernelNetwork();
  mlp_kernel::Gradient grad;
  for (std::size_t l = 0; gradient && l < net.weights().size(); ++l) {
    for (Tensor* p : {&net.weights()[l], &net.biases()[l]})
      if (!p->grad().defined()) p->mutable_grad() = torch::zeros_like(*p);
    grad.weights.push_back(net.weights()[l].grad().data_ptr<float>());
    grad.biases.push_back(net.biases()[l].grad().data_ptr<float>());
  }
  const bool exact = config.boundary.kind == DemConfig::Boundary::kExact;
  mlp_kernel::Problem pb;
  pb.mu = material->mu();
  pb.lambda = scenario.material.lambda();
  pb.decoupled = scenario.material.model == "neo_hookean_decoupled";
  pb.kappa = material->kappa();
  pb.load_scale = scale;
  pb.output_scale = out_scale;
  pb.energy_scale = energy_scale;
  pb.volume = {draw.x.size(0), floats(draw.x), floats(draw.vol), floats(draw.body)};
  if (exact) {
    pb.volume.g = floats(draw.lift[0]);
    pb.volume.grad_g = floats(draw.lift[1]);
    pb.volume.D = floats(draw.lift[2]);
    pb.volume.grad_D = floats(draw.lift[3]);
  }
  pb.loads = {xs.size(0), floats(xs), floats(traction_area), exact ? floats(lift_s[0]) : nullptr,
              exact ? floats(lift_s[2]) : nullptr};
  if (!exact && xc.size(0) > 0)
    pb.penalty = {xc.size(0), floats(xc), floats(fixed_value), floats(fixed_mask), config.boundary.penalty_weight};
  const mlp_kernel::Result r =
      mlp_kernel::energyAndGradient(nn, pb, gradient ? &grad : nullptr, kernelThreads(config.threads, pb.volume.n));
  if (energy) *energy = r.energy;
  if (min_J) *min_J = r.min_J;
  return torch::full({}, r.admissible ? r.loss : std::nan(""), torch::kFloat64);
}

// Gauss points (2 per axis) in the cells of a grid of lbfgs.cell_spacings particle spacings over
// the body the cloud describes, cut cells moment-fitted (cell_quadrature.hpp), with
// the lift there: the same points whatever sampler made the cloud. `shift` moves the grid by
// that fraction of a cell along each axis.
DemSolver::Impl::JitterDraw DemSolver::Impl::cellQuadratureDraw(double shift) {
  const double spacing = interiorParticleSpacing(cloud);
  const torch_support::BodyBox box = torch_support::bodyBox(cloud);
  // No finer than a sixth of the body's smallest dimension (the matrix's coarsest spacing): past
  // that the points' cost grows with the cloud and the field does not change (Beam3D's 1/10 grid
  // cloud at one spacing: 32k points).
  const double cell = std::max(config.lbfgs.cell_spacings * spacing, box.half.minCoeff() / 3.0);
  // Half a spacing of margin as the grid DEM's. Shifted: a cell more on each side, so that moving
  // the box (the grid is centred on it) still covers the body.
  const Eigen::Vector3d margin = Eigen::Vector3d::Constant(0.5 * spacing + (shift > 0 ? cell : 0.0));
  const Eigen::Vector3d offset = Eigen::Vector3d::Constant(shift * cell);
  const BsplineGrid cells(box.center - box.half - margin - offset, box.center + box.half + margin - offset, cell, 1);
  CellQuadratureConfig cq;
  cq.points_per_axis = 2;
  // Cut cells moment-fitted whole by default: split, a thin body's cells hold 8x the points.
  cq.boundary_levels = config.lbfgs.cell_boundary_levels;
  cq.threads = config.threads;
  const CellQuadrature q = cellQuadrature(cloud, cells, cq);
  const DirichletLift lift = liftAt(q.points);
  std::vector<Eigen::Vector3d> body_forces(q.points.size());
  for (std::size_t i = 0; i < q.points.size(); ++i) body_forces[i] = q.weights[i] * scenario.body_force;
  JitterDraw draw;
  draw.x = toTensor(q.points, dtype);
  draw.vol = toTensor(q.weights, dtype);
  draw.body = toTensor(body_forces, dtype);
  draw.lift[0] = toTensor(lift.g, dtype);
  draw.lift[1] = toTensor(lift.grad_g, dtype);
  draw.lift[2] = toTensor(lift.D, dtype);
  draw.lift[3] = toTensor(lift.grad_D, dtype);
  if (config.verbose)
    std::cerr << "dem: MLP quadrature " << q.points.size() << " Gauss points in cells of " << cells.cell() << " m"
              << (shift > 0 ? " (shifted: the exploit guard's)" : "") << "\n";
  return draw;
}

const DemSolver::Impl::JitterDraw& DemSolver::Impl::cellDraw() {
  if (!cell_draw.x.defined()) cell_draw = cellQuadratureDraw(0.0);
  return cell_draw;
}

const DemSolver::Impl::JitterDraw& DemSolver::Impl::shiftedCellDraw() {
  if (!shifted_cell_draw.x.defined()) shifted_cell_draw = cellQuadratureDraw(0.5);
  return shifted_cell_draw;
}

}  // namespace demnerf::mechanics
