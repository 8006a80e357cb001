#pragma once
// The exact-Dirichlet construction u = g(X) + D(X) z(X): per displacement component, a smooth
// distance D to the fixtures that constrain it and a lift g that takes each fixture's value on it.

#include <Eigen/Core>
#include <vector>

#include "demnerf/core/scenario.hpp"

namespace demnerf::mechanics {

struct HeldFace;  // held_face.hpp

/// g, D and their gradients at points, for a scenario's fixtures at full load.
struct DirichletLift {
  std::vector<Eigen::Vector3d> g;          ///< lift: equals the prescribed value on each fixture
  std::vector<Eigen::Matrix3d> grad_g;     ///< (i, k) = d g_i / d X_k
  std::vector<Eigen::Vector3d> D;          ///< distance factor: 0 on fixtures constraining component i
  std::vector<Eigen::Matrix3d> grad_D;     ///< (i, k) = d D_i / d X_k
};

/// Distance from a point to a region (0 inside).
double regionDistance(const core::Region& region, const Eigen::Vector3d& x);

/// Signed distance from a point to a region's boundary (negative inside; exact for boxes, spheres
/// and halfspaces). regionDistance is its positive part.
double regionSignedDistance(const core::Region& region, const Eigen::Vector3d& x);

/// g, grad g, D, grad D at one point, with analytic gradients (one-sided 0 inside a fixture,
/// where the distance is flat). Cheap enough to call for every quadrature point every step.
/// `held` (one per fixture, heldFaces): a fixture with a valid face has D = the distance to that
/// face, so the rest of its band is free; without `held`, or with an invalid face, D is the
/// distance to the fixture's region and its whole volume is held.
/// `signed_faces`: a held face's distance is signed (negative beyond the face, heldFaceDistance),
/// so D and g continue linearly through the face. Quadrature points a little outside the body
/// beyond a held face (cut cells of a random or Poisson cloud: 13 % of the MLP's weight on the
/// compression cube) then see the field's smooth continuation; with |distance| D folds there, and
/// the compression cube's homogeneous answer u_x = (b - 1) x, D_x z with z constant, cannot be
/// represented on both sides of x = 0 (the MLP's answers were 6.6 % off).
void dirichletLiftAt(const core::Scenario& scenario, const Eigen::Vector3d& x, double length, Eigen::Vector3d& g,
                     Eigen::Matrix3d& grad_g, Eigen::Vector3d& D, Eigen::Matrix3d& grad_D,
                     const std::vector<HeldFace>* held = nullptr, bool signed_faces = false);

/// `length` normalises distances (the body's size), so D is O(1) over the body. Components no
/// fixture constrains get D = 1, g = 0.
DirichletLift dirichletLift(const core::Scenario& scenario, const std::vector<Eigen::Vector3d>& points, double length,
                            const std::vector<HeldFace>* held = nullptr, bool signed_faces = false);

}  // namespace demnerf::mechanics
