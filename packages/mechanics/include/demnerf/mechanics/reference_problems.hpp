#pragma once
// Problems with known answers, shared by tests and benchmarks: Cook's membrane (deal.II code
// gallery) and homogeneous uniaxial stretch (closed form).

#include <Eigen/Core>
#include <string>

#include "demnerf/core/scenario.hpp"
#include "demnerf/mechanics/material.hpp"
#include "demnerf/mechanics/tet_mesh.hpp"

namespace demnerf::mechanics {

/// Cook's membrane in SI units: corners (0,0) (48,44) (48,60) (0,44) mm, 1 mm thick, plane
/// strain (u_z = 0 everywhere), left edge clamped, 1 N dead shear load on the right edge in
/// 10 steps, decoupled Neo-Hookean mu = 422.5 kPa, nu = 0.3.
core::Scenario cookMembraneScenario();
/// The membrane meshed with `cells` x `cells` x 1 hexes split into tetrahedra of `order`.
TetMesh cookMembraneMesh(int cells, int order);
/// The point whose y-displacement is the reference figure: (48, 52, 0.5) mm, the middle of the
/// loaded edge (the deal.II gallery's current evaluation point, after Miehe 1994).
Eigen::Vector3d cookMembraneTip();
/// Converged reference y-displacement there (m): deal.II gallery, Q2, plane strain, 32-64 cells
/// per edge. (Its older 14.33 mm was the corner (48, 60) of a slab whose z faces were free.)
constexpr double kCookTipReference = 14.74e-3;

/// The unit cube [0,1]^3 on rollers (each x_i = 0 face holds u_i = 0) pulled by a uniform dead
/// traction P11 on x = 1; E = 1 MPa, nu = 0.3 (`model` picks the Neo-Hookean form).
core::Scenario uniaxialTractionScenario(double p11, const std::string& model = "neo_hookean");
/// Lateral stretch b of a homogeneous uniaxial state F = diag(a, b, b) with traction-free sides.
double uniaxialLateralStretch(const HyperelasticMaterial& material, double a);
/// Axial stretch a (and lateral b) under a uniaxial first Piola-Kirchhoff stress P11.
double uniaxialStretchForStress(const HyperelasticMaterial& material, double p11, double* lateral);

}  // namespace demnerf::mechanics
