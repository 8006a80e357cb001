#pragma once
// Conversions between transforms.json camera poses (OpenGL) and REP-103 optical frames.

#include <Eigen/Geometry>

namespace demnerf::core {

/// transforms.json stores camera-to-world with the camera looking down -z, y up (OpenGL).
/// Our cameras use the optical frame: z forward, x right, y down. The two differ by a
/// rotation of pi about the camera's x axis.
Eigen::Isometry3d openGlToOptical(const Eigen::Isometry3d& world_from_gl_camera);
Eigen::Isometry3d opticalToOpenGl(const Eigen::Isometry3d& world_from_optical_camera);

/// True when the matrix is a finite rigid transform (orthonormal rotation, last row 0 0 0 1).
bool isRigidTransform(const Eigen::Matrix4d& matrix, double tolerance = 1e-3);

/// Rigid transform nearest to a 4x4 matrix (re-orthonormalises the rotation via SVD), so
/// small numeric drift in a file does not shear the cameras.
Eigen::Isometry3d nearestRigidTransform(const Eigen::Matrix4d& matrix);

}  // namespace demnerf::core
