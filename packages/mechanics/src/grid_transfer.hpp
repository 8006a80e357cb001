#pragma once
// Moving a B-spline field from one grid to another (the DEM's nested grid solve,
// dem_grid_nested.cpp): the answer of a coarse grid starts the Newton on the fine one.
// Private to packages/mechanics/src.

#include <Eigen/Core>
#include <vector>

#include "demnerf/mechanics/bspline_grid.hpp"

namespace demnerf::mechanics {

/// The coefficients (to.nodeCount() x 3) whose field N_to C best fits N_from C_from in weighted
/// least squares at the points, sum_q w_q |N_to(x_q) C - N_from(x_q) C_from|^2. Exact (to rounding)
/// when the field lies in `to`'s span and the points determine it: a coarse grid's field on a grid
/// with its cells halved and aligned (knot insertion). Nodes no point sees get 0. Throws
/// core::Error for mismatched sizes.
Eigen::MatrixXd transferGridField(const BsplineGrid& from, const Eigen::MatrixXd& C_from, const BsplineGrid& to,
                                  const std::vector<Eigen::Vector3d>& points, const std::vector<double>& weights);

/// Continues a grid's field C onto the nodes that the `targets` reach but its own quadrature
/// (`points`, `weights`) never saw, whose coefficients its Newton left at 0: each such node gets
/// the extension's Lagrange extrapolation (bspline_extension.hpp) from the nearest cell filled to
/// `fill`, the value the field's polynomial continuation gives it. Nodes with no such cell within
/// the extension's reach keep their value. Why: a coarse level of the nested solve sees less of a
/// ragged body than the fine grid (its cut cells are not split), and its field read with those
/// zeros falls from the twisted displacement to none within one coarse cell: det F up to 4 at the
/// fine grid's points there (docs/dem_feature_grid.md, "A slow NeRF T-bar cloud: the cause").
/// Returns how many nodes were continued.
long continueUnseenNodes(const BsplineGrid& grid, Eigen::MatrixXd& C, const std::vector<Eigen::Vector3d>& points,
                         const std::vector<double>& weights, const std::vector<Eigen::Vector3d>& targets, double fill);

}  // namespace demnerf::mechanics
