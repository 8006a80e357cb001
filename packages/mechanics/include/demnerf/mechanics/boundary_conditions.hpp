#pragma once
// Scenario loads and fixtures resolved on a set of points: tractions that carry a load's exact
// force and torque, and the prescribed displacement components of fixtures.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <functional>
#include <string>
#include <vector>

#include "demnerf/core/ply.hpp"
#include "demnerf/core/scenario.hpp"

namespace demnerf::mechanics {

/// A linear traction field t(x) = a + b x (x - c) over a patch: with c the area-weighted
/// centroid, sum t_i A_i = force and sum (x_i - c) x t_i A_i = torque hold exactly.
struct WrenchTraction {
  Eigen::Vector3d a = Eigen::Vector3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  Eigen::Vector3d at(const Eigen::Vector3d& x) const { return a + b.cross(x - centroid); }
};

/// Solves the traction field for a patch of weighted points (areas > 0). `what` names the load
/// in errors (an empty patch, or a torque about an axis the patch cannot resist, e.g. a line).
WrenchTraction spreadWrench(const std::vector<Eigen::Vector3d>& points, const std::vector<double>& areas,
                            const Eigen::Vector3d& force, const Eigen::Vector3d& torque, const std::string& what);

/// Prescribed displacement components per point: mask(c) != 0 where component c is fixed.
struct Dirichlet {
  std::vector<int> index;                 ///< constrained points, ascending
  std::vector<Eigen::Vector3d> value;     ///< prescribed displacement (full load)
  std::vector<Eigen::Vector3i> mask;      ///< which components are prescribed
};

/// Fixtures resolved on points: a point inside several fixtures takes each component from the
/// last fixture that constrains it. Throws core::Error when the scenario has no fixture (rigid
/// motion) or a fixture selects no point.
Dirichlet resolveFixtures(const core::Scenario& scenario, const std::vector<Eigen::Vector3d>& points);

/// resolveFixtures' rule on `count` points of which fixture f holds held_by(f) (indices), for
/// solvers that choose the held points otherwise (a fixture that holds a face: held_face.hpp).
/// `what` names the points in the error for a fixture that holds none.
Dirichlet assembleFixtures(const core::Scenario& scenario, std::size_t count,
                           const std::function<std::vector<int>(std::size_t)>& held_by, const std::string& what);

/// Traction per particle (zero for interior particles and outside every load region) at full
/// load; loads spread over the surface particles (area > 0) in their region. Throws core::Error
/// naming the load and its region when it selects no surface particle.
std::vector<Eigen::Vector3d> particleTractions(const core::Scenario& scenario, const core::ParticleCloud& cloud);

/// Throws SolveError{SolveFailure::kDegenerate} when the fixed components cannot give a unique
/// equilibrium: no particle fixed, every particle fully fixed (nothing to solve), or a rigid-body
/// motion left free (one pinned particle, pins on a line, rollers that allow a slide). `what` names
/// the scenario in the message. Runs in O(fixed particles), before anything is factorised.
void checkSupports(const Dirichlet& dirichlet, const core::ParticleCloud& cloud, const std::string& what);

/// Everything a particle solver checks before it starts: the scenario, the cloud, that volumes
/// are positive, fixtures and loads select particles, and checkSupports (SolveError kDegenerate).
void validateProblem(const core::Scenario& scenario, const core::ParticleCloud& cloud);

}  // namespace demnerf::mechanics
