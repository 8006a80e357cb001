#pragma once
// core particle clouds and results <-> sensor_msgs/PointCloud2 (the fields of DESIGN.md).

#include <sensor_msgs/PointCloud2.h>

#include <cstdint>
#include <limits>

#include "demnerf/core/ply.hpp"

namespace dem_nerf {

/// Fields x y z volume nx ny nz area rgb (rgb packed as float, as rviz expects).
sensor_msgs::PointCloud2 toPointCloud2(const demnerf::core::ParticleCloud& cloud, const std_msgs::Header& header);

/// Reads the particle fields back after checking the whole layout (CloudLayout); throws
/// demnerf::core::Error naming a bad size, step, offset or datatype, a missing field, an empty
/// cloud, more than max_points points, or a NaN. A cloud with only x y z gets unit volumes and no
/// surface information.
demnerf::core::ParticleCloud particlesFromPointCloud2(
    const sensor_msgs::PointCloud2& message, std::uint64_t max_points = std::numeric_limits<std::uint64_t>::max());

/// Fields x y z (rest position) ux uy uz von_mises, plus rgb coloured by displacement magnitude.
sensor_msgs::PointCloud2 toPointCloud2(const demnerf::core::ResultField& result, const std_msgs::Header& header,
                                       bool displaced_positions);

/// Reads a result cloud back (x y z ux uy uz von_mises); with displaced_positions, x y z are the
/// deformed positions and the rest positions are x - u. Throws demnerf::core::Error naming a
/// missing field, an empty cloud or a NaN.
demnerf::core::ResultField resultFromPointCloud2(const sensor_msgs::PointCloud2& message, bool displaced_positions);

}  // namespace dem_nerf
