#pragma once
// ParaView export: a solver's answer written as a VTK XML unstructured grid (.vtu) by VTK's own
// vtkXMLUnstructuredGridWriter, with the fields a user colours and warps by.

#include <Eigen/Core>
#include <string>
#include <vector>

#include "demnerf/core/ply.hpp"
#include "demnerf/mechanics/tet_mesh.hpp"

namespace demnerf::vtk_export {

/// The names of the point data arrays every file carries (ParaView lists them by these names).
inline constexpr const char* kDisplacement = "displacement";  ///< 3 components, m
inline constexpr const char* kVonMises = "von_mises";         ///< Pa (NaN where det F <= 0)
inline constexpr const char* kVolume = "volume";              ///< m^3 (rest volume)

/// The particles at their rest positions, one VTK_VERTEX cell each, with point data
/// displacement, von_mises (both from the solver's answer, whose stresses come from the exact
/// gradient of its displacement field) and volume (the particle's quadrature volume; surface
/// particles carry 0). ParaView's "Warp By Vector" on displacement shows the deformed body.
/// Throws core::Error when the sizes differ or the file cannot be written (the message names
/// the path and why).
void writeParticlesVtu(const std::string& path, const core::ParticleCloud& cloud, const core::ResultField& result);

/// The FEM mesh at rest with the solution at its nodes: VTK_TETRA (order 1) or
/// VTK_QUADRATIC_TETRA (order 2, whose edge-node order is the mesh's) cells; point data
/// displacement, von_mises and volume (each element's volume shared equally by its nodes, so
/// the volumes sum to the mesh's); cell data element_volume. Throws core::Error as above.
void writeTetMeshVtu(const std::string& path, const mechanics::TetMesh& mesh,
                     const std::vector<Eigen::Vector3d>& displacement, const std::vector<double>& von_mises);

}  // namespace demnerf::vtk_export
