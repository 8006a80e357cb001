#pragma once
// FemSolver's state and parts, private to packages/mechanics/src:
//   fem_assembly.cpp  quadrature, loads, energy, residual and tangent
//   fem_pattern.cpp   the tangent's sparsity: element colours, node order, free dofs, scatter
//   fem_newton.cpp    the linear solves, Newton with its line search, and the load stepping
//   fem_solver.cpp    the public FemSolver and interpolation at arbitrary points

#include <Eigen/Sparse>
#include <array>
#include <memory>
#include <vector>

#include "demnerf/mechanics/fem_solver.hpp"
#include "demnerf/mechanics/material.hpp"
#include "fem_factor.hpp"

namespace demnerf::mechanics {

using SparseMatrix = Eigen::SparseMatrix<double>;

struct FemSolver::Impl {
  TetMesh mesh;
  core::Scenario scenario;
  FemConfig config;
  std::unique_ptr<HyperelasticMaterial> material;
  int n = 4;  // nodes per element
  int nq = 1;
  int threads = 1;
  std::vector<double> dNdX;    // per element and quadrature point, n x 3 row-major
  std::vector<double> weight;  // reference volume weight of each quadrature point
  std::vector<Eigen::Matrix<double, 4, 3>> grad_l;  // per element d L / d X
  Eigen::VectorXd f_ext;              // consistent nodal forces at full load
  Eigen::VectorXd prescribed;         // full-load values of constrained dofs
  std::vector<int> free_index;        // dof -> free dof number or -1
  int n_free = 0;
  Eigen::VectorXd u;
  FemResult result;
  // Free-free tangent, lower triangle, pattern fixed at setup; `scatter` holds for every element
  // and local dof pair (r >= c, packed) the position of its entry in K's values (-1: constrained).
  SparseMatrix K;
  std::vector<int> scatter;
  std::vector<std::vector<int>> colours;  // element ids; no two in a colour share a node
  FemFactor factor;  // of K (fem_factor.hpp)
  bool analysed = false, factor_valid = false;
  bool step_shifted = false;  // the last linear solve used a shifted factor (fem_factor.hpp)
  // The running solve's clock (null: no budget, no reports) and the last converged load fraction.
  SolveClock* clock = nullptr;
  double done = 0.0;
  // Why the last Newton loop failed.
  enum class Failure { kNone, kInverted, kStalled };
  Failure failure = Failure::kNone;
  // Interpolation grid: element ids per cell.
  Eigen::Vector3d grid_lower, grid_cell;
  Eigen::Vector3i grid_dims;
  std::vector<std::vector<int>> grid;

  std::array<Eigen::Vector3d, 4> corners(int e) const {
    const auto& el = mesh.elements[e];
    return {mesh.nodes[el[0]], mesh.nodes[el[1]], mesh.nodes[el[2]], mesh.nodes[el[3]]};
  }
  Eigen::VectorXd elementDofs(const Eigen::VectorXd& x, int e) const {
    Eigen::VectorXd ue(3 * n);
    for (int a = 0; a < n; ++a) ue.segment<3>(3 * a) = x.segment<3>(3 * mesh.elements[e][a]);
    return ue;
  }

  void setup();
  void setupLoads(const std::vector<BoundaryFace>& faces);

  void setupPattern();
  void buildGrid();
  double energy(const Eigen::VectorXd& x, double scale) const;
  // Residual R = f_int - scale f_ext over all dofs, the free-free tangent into K, and K_fc du_c.
  double assemble(const Eigen::VectorXd& x, double scale, const Eigen::VectorXd& du, bool du_constrained,
                  Eigen::VectorXd& R, Eigen::VectorXd& Kdu_c, double& internal_norm);
  template <int N>
  double assembleT(const Eigen::VectorXd& x, const Eigen::VectorXd& du, bool du_constrained, Eigen::VectorXd& f_int,
                   Eigen::VectorXd& Kdu_c);
  template <int N>
  double elementEnergy(const Eigen::VectorXd& x, int e) const;
  bool newton(double scale);
  // Whether the full Newton step du lowers the free residual below `res` (the fallback when the
  // energy is flat within round-off).
  bool residualFalls(const Eigen::VectorXd& du, double scale, double res);
  const FemResult& solveAll();
  void keepState();  // u -> result.displacement
  // eta: relative accuracy asked of an iterative solve (inexact Newton forcing term).
  Eigen::VectorXd solveLinear(const Eigen::VectorXd& rhs, double eta);
  int locate(const Eigen::Vector3d& x, Eigen::Vector4d& L) const;
  bool nd() const { return config.ordering == FemConfig::Ordering::kNestedDissection; }
  Eigen::VectorXd factorSolve(const Eigen::VectorXd& b) const { return factor.solve(b); }
};

}  // namespace demnerf::mechanics
