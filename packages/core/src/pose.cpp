#include "demnerf/core/pose.hpp"

#include <Eigen/SVD>

namespace demnerf::core {
namespace {

// Rotation by pi about x: maps OpenGL camera axes (x right, y up, z back) to optical axes
// (x right, y down, z forward). It is its own inverse.
Eigen::Isometry3d flipYZ() {
  Eigen::Isometry3d flip = Eigen::Isometry3d::Identity();
  flip.linear() = Eigen::Vector3d(1.0, -1.0, -1.0).asDiagonal();
  return flip;
}

}  // namespace

Eigen::Isometry3d openGlToOptical(const Eigen::Isometry3d& world_from_gl_camera) {
  return world_from_gl_camera * flipYZ();
}

Eigen::Isometry3d opticalToOpenGl(const Eigen::Isometry3d& world_from_optical_camera) {
  return world_from_optical_camera * flipYZ();
}

bool isRigidTransform(const Eigen::Matrix4d& matrix, double tolerance) {
  if (!matrix.allFinite()) return false;
  const Eigen::Matrix3d rotation = matrix.topLeftCorner<3, 3>();
  const bool orthonormal = (rotation.transpose() * rotation - Eigen::Matrix3d::Identity())
                               .cwiseAbs().maxCoeff() < tolerance;
  const bool proper = rotation.determinant() > 0.0;
  const bool last_row = (matrix.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() < 1e-9;
  return orthonormal && proper && last_row;
}

Eigen::Isometry3d nearestRigidTransform(const Eigen::Matrix4d& matrix) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(matrix.topLeftCorner<3, 3>(),
                                              Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d rotation = svd.matrixU() * svd.matrixV().transpose();
  if (rotation.determinant() < 0.0) {
    Eigen::Matrix3d u = svd.matrixU();
    u.col(2) *= -1.0;
    rotation = u * svd.matrixV().transpose();
  }
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = rotation;
  pose.translation() = matrix.topRightCorner<3, 1>();
  return pose;
}

}  // namespace demnerf::core
