#pragma once
// Space carving for a capture that saw its object from some sides only: a grid node is space some
// camera saw as empty when it lies in that camera's image and the camera's ray to it reaches it
// before meeting the body; every other node is kept as possibly solid (the visual hull of what
// the cameras saw, intersected with the box). Used by solidifyField to fill the back of a head
// photographed from the front without filling the space beside it that oblique cameras saw.

#include <Eigen/Geometry>
#include <cstddef>
#include <vector>

#include "demnerf/core/camera.hpp"
#include "demnerf/geometry/density_grid.hpp"

namespace demnerf::geometry {

/// One camera of the capture: intrinsics (with their image size) and pose, the REP-103 optical
/// frame (z forward) in the frame the grid's nodes are in, as core::Frame holds them.
struct ViewCamera {
  core::PinholeCamera camera;
  Eigen::Isometry3d world_from_camera = Eigen::Isometry3d::Identity();
};

struct CarvingReport {
  std::size_t seen_empty = 0;  ///< non-body nodes at least one camera saw unobstructed
  std::size_t hidden = 0;      ///< non-body nodes inside some image but hidden from every such camera
  std::size_t unseen = 0;      ///< non-body nodes inside no camera's image
};

/// 1 for each node outside `body` that fewer than `min_views` cameras saw as empty; with
/// min_views 1 (the visual hull), for every camera that has the node inside its image (in front
/// of it, projecting inside width x height with its distortion), the body lies between them.
/// A larger min_views asks for more evidence before space counts as empty: a thin part seen
/// edge-on by one or two grazing views (the fox's ears) keeps what lies behind it. The body occludes as cubes of one cell around its nodes: each camera
/// renders their depths into a depth map with about two texels per cell at the body's far side,
/// and a node counts as hidden when it lies more than a cell's half-diagonal behind that depth.
/// Nodes no camera has in its image count as not seen (1). Throws core::Error for no cameras,
/// invalid intrinsics or min_views < 1. Cost: O(body nodes + nodes) per camera.
std::vector<char> unseenByCameras(const DensityGrid& grid, const std::vector<char>& body,
                                  const std::vector<ViewCamera>& cameras, int min_views = 1,
                                  CarvingReport* report = nullptr);

}  // namespace demnerf::geometry
