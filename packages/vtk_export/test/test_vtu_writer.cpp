// The .vtu files read back with VTK's own reader: the grid, the field names and the numbers must
// be the solver's, and the stresses those of the closed-form uniaxial state.
#include <gtest/gtest.h>

#include <vtkCell.h>
#include <vtkCellData.h>
#include <vtkCellType.h>
#include <vtkDataArray.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLUnstructuredGridReader.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <unistd.h>

#include "demnerf/core/error.hpp"
#include "demnerf/mechanics/box_particles.hpp"
#include "demnerf/mechanics/material.hpp"
#include "demnerf/mechanics/reference_problems.hpp"
#include "demnerf/mechanics/simulate.hpp"
#include "demnerf/vtk_export/vtu_writer.hpp"

namespace dm = demnerf::mechanics;
namespace core = demnerf::core;
namespace fs = std::filesystem;
using Eigen::Vector3d;

namespace {

fs::path scratch(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("demnerf_vtk_export_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir / name;
}

/// The grid as VTK reads it back (nullptr if the reader failed).
vtkSmartPointer<vtkUnstructuredGrid> readBack(const fs::path& path) {
  vtkNew<vtkXMLUnstructuredGridReader> reader;
  reader->SetFileName(path.c_str());
  reader->Update();
  if (reader->GetErrorCode() != 0) return nullptr;
  return reader->GetOutput();
}

// The unit cube on rollers pulled by P11 on x = 1 (reference_problems): a homogeneous state, so
// the linear FEM is exact and the stress everywhere is the closed form's.
struct Uniaxial {
  core::ParticleCloud cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(1, 1, 1), Eigen::Vector3i(4, 4, 4));
  dm::SimulationOutcome solve(double p11, bool keep_mesh) const {
    dm::SimulateOptions options;
    options.voxel.order = 1;
    options.mesher = dm::SimulateOptions::Mesher::kVoxel;  // the particles' own cells:
    options.voxel.cell = 0.25;                                // mesh nodes on the fixture faces
    options.keep_fem_mesh = keep_mesh;
    return dm::simulate(cloud, dm::uniaxialTractionScenario(p11), dm::SolverChoice::kFem, options);
  }
};

/// sigma_11 = P11 F11 / J = P11 / b^2 for F = diag(a, b, b); the other stresses vanish, so
/// von Mises equals |sigma_11|.
double uniaxialVonMises(double p11) {
  const core::Scenario s = dm::uniaxialTractionScenario(p11);
  double b = 0;
  dm::uniaxialStretchForStress(*dm::makeMaterial(s.material), p11, &b);
  return std::abs(p11) / (b * b);
}

TEST(VtuExport, ParticlesReadBackWithTheSolversNumbers) {
  const Uniaxial problem;
  const double p11 = 2e5;  // 20 % of E: a clearly non-linear stretch
  const dm::SimulationOutcome out = problem.solve(p11, false);
  const fs::path path = scratch("particles.vtu");
  demnerf::vtk_export::writeParticlesVtu(path.string(), problem.cloud, out.field);
  EXPECT_FALSE(fs::exists(path.string() + ".part"));  // moved into place

  const auto grid = readBack(path);
  ASSERT_NE(grid, nullptr) << "VTK could not read " << path;
  ASSERT_EQ(grid->GetNumberOfPoints(), static_cast<vtkIdType>(problem.cloud.size()));
  ASSERT_EQ(grid->GetNumberOfCells(), static_cast<vtkIdType>(problem.cloud.size()));
  EXPECT_EQ(grid->GetCellType(0), VTK_VERTEX);
  vtkDataArray* u = grid->GetPointData()->GetArray("displacement");
  vtkDataArray* vm = grid->GetPointData()->GetArray("von_mises");
  vtkDataArray* volume = grid->GetPointData()->GetArray("volume");
  ASSERT_NE(u, nullptr);
  ASSERT_NE(vm, nullptr);
  ASSERT_NE(volume, nullptr);
  EXPECT_EQ(u->GetNumberOfComponents(), 3);
  EXPECT_EQ(grid->GetPointData()->GetVectors(), u);  // what Warp By Vector picks

  const double expected_vm = uniaxialVonMises(p11);
  double volume_sum = 0;
  for (vtkIdType i = 0; i < grid->GetNumberOfPoints(); ++i) {
    double x[3];
    grid->GetPoint(i, x);
    for (int c = 0; c < 3; ++c) {
      EXPECT_EQ(x[c], problem.cloud.positions[i](c));  // rest positions, bit for bit
      EXPECT_EQ(u->GetComponent(i, c), out.field.displacements[i](c));
    }
    EXPECT_EQ(vm->GetComponent(i, 0), out.field.von_mises[i]);
    EXPECT_NEAR(vm->GetComponent(i, 0), expected_vm, 1e-6 * expected_vm);
    EXPECT_EQ(volume->GetComponent(i, 0), problem.cloud.volumes[i]);
    volume_sum += volume->GetComponent(i, 0);
  }
  EXPECT_NEAR(volume_sum, 1.0, 1e-12);  // the unit cube
  EXPECT_GT(out.max_displacement, 0.1);
}

TEST(VtuExport, NoLoadNoStressAndASmallLoadItsOwnStress) {
  const Uniaxial problem;
  // 0 Pa: the body stays put and carries no stress; 1 Pa on a 1 MPa solid: von Mises 1 Pa.
  for (const double p11 : {0.0, 1.0}) {
    const dm::SimulationOutcome out = problem.solve(p11, false);
    const fs::path path = scratch("small_load.vtu");
    demnerf::vtk_export::writeParticlesVtu(path.string(), problem.cloud, out.field);
    const auto grid = readBack(path);
    ASSERT_NE(grid, nullptr);
    vtkDataArray* vm = grid->GetPointData()->GetArray("von_mises");
    vtkDataArray* u = grid->GetPointData()->GetArray("displacement");
    ASSERT_TRUE(vm && u);
    for (vtkIdType i = 0; i < vm->GetNumberOfTuples(); ++i) {
      EXPECT_NEAR(vm->GetComponent(i, 0), p11, 1e-3) << "load " << p11;
      if (p11 == 0.0) EXPECT_EQ(u->GetComponent(i, 0), 0.0);
    }
  }
}

TEST(VtuExport, FemMeshReadsBackAsTetrahedraWithNodalFields) {
  const Uniaxial problem;
  const double p11 = 2e5;
  const dm::SimulationOutcome out = problem.solve(p11, true);
  ASSERT_NE(out.fem_mesh, nullptr);
  const dm::FemMeshSolution& fem = *out.fem_mesh;
  const fs::path path = scratch("mesh.vtu");
  demnerf::vtk_export::writeTetMeshVtu(path.string(), fem.mesh, fem.displacement, fem.von_mises);

  const auto grid = readBack(path);
  ASSERT_NE(grid, nullptr);
  ASSERT_EQ(grid->GetNumberOfPoints(), static_cast<vtkIdType>(fem.mesh.nodes.size()));
  ASSERT_EQ(grid->GetNumberOfCells(), static_cast<vtkIdType>(out.mesh_elements));
  EXPECT_EQ(grid->GetCellType(0), VTK_TETRA);
  vtkDataArray* u = grid->GetPointData()->GetArray("displacement");
  vtkDataArray* vm = grid->GetPointData()->GetArray("von_mises");
  vtkDataArray* volume = grid->GetPointData()->GetArray("volume");
  vtkDataArray* element_volume = grid->GetCellData()->GetArray("element_volume");
  ASSERT_TRUE(u && vm && volume && element_volume);
  double a = 0, b = 0;
  a = dm::uniaxialStretchForStress(*dm::makeMaterial(dm::uniaxialTractionScenario(p11).material), p11, &b);
  double node_volume = 0, cell_volume = 0;
  for (vtkIdType i = 0; i < grid->GetNumberOfPoints(); ++i) {
    double X[3];
    grid->GetPoint(i, X);
    // The homogeneous field u = ((a-1) X, (b-1) Y, (b-1) Z) at every node.
    EXPECT_NEAR(u->GetComponent(i, 0), (a - 1) * X[0], 1e-8);
    EXPECT_NEAR(u->GetComponent(i, 1), (b - 1) * X[1], 1e-8);
    EXPECT_NEAR(u->GetComponent(i, 2), (b - 1) * X[2], 1e-8);
    EXPECT_NEAR(vm->GetComponent(i, 0), uniaxialVonMises(p11), 1e-6 * uniaxialVonMises(p11));
    node_volume += volume->GetComponent(i, 0);
  }
  for (vtkIdType e = 0; e < grid->GetNumberOfCells(); ++e) cell_volume += element_volume->GetComponent(e, 0);
  EXPECT_NEAR(node_volume, 1.0, 1e-12);
  EXPECT_NEAR(cell_volume, 1.0, 1e-12);
}

TEST(VtuExport, QuadraticTetrahedraKeepTheirTenNodes) {
  const dm::TetMesh mesh = dm::structuredBoxMesh(Vector3d(0, 0, 0), Vector3d(2, 1, 1), Eigen::Vector3i(2, 1, 1), 2);
  std::vector<Vector3d> u(mesh.nodes.size());
  for (std::size_t i = 0; i < u.size(); ++i) u[i] = 0.01 * mesh.nodes[i];
  const std::vector<double> vm(mesh.nodes.size(), 0.0);
  const fs::path path = scratch("quadratic.vtu");
  demnerf::vtk_export::writeTetMeshVtu(path.string(), mesh, u, vm);
  const auto grid = readBack(path);
  ASSERT_NE(grid, nullptr);
  ASSERT_EQ(grid->GetNumberOfCells(), static_cast<vtkIdType>(mesh.elements.size()));
  EXPECT_EQ(grid->GetCellType(0), VTK_QUADRATIC_TETRA);
  // VTK's own measure of each cell (from its corners) must be the element's volume.
  vtkDataArray* element_volume = grid->GetCellData()->GetArray("element_volume");
  ASSERT_NE(element_volume, nullptr);
  double total = 0;
  for (vtkIdType e = 0; e < grid->GetNumberOfCells(); ++e) total += element_volume->GetComponent(e, 0);
  EXPECT_NEAR(total, 2.0, 1e-12);
  // The edge nodes stay where the mesh put them: the midpoint of each edge.
  vtkCell* cell = grid->GetCell(0);
  ASSERT_EQ(cell->GetNumberOfPoints(), 10);
  double p0[3], p1[3], mid[3];
  grid->GetPoint(cell->GetPointId(0), p0);
  grid->GetPoint(cell->GetPointId(1), p1);
  grid->GetPoint(cell->GetPointId(4), mid);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(mid[c], 0.5 * (p0[c] + p1[c]), 1e-12);
}

TEST(VtuExport, BadInputIsRefusedWithTheReason) {
  core::ParticleCloud cloud = dm::makeBoxParticles(Vector3d(0, 0, 0), Vector3d(1, 1, 1), Eigen::Vector3i(2, 2, 2));
  core::ResultField result;
  result.resize(cloud.size());
  result.positions = cloud.positions;
  const std::string missing_folder = (scratch("x").parent_path() / "no_such_folder" / "out.vtu").string();
  try {
    demnerf::vtk_export::writeParticlesVtu(missing_folder, cloud, result);
    FAIL() << "a missing folder was accepted";
  } catch (const core::Error& error) {
    EXPECT_NE(std::string(error.what()).find("does not exist"), std::string::npos) << error.what();
  }
  result.resize(cloud.size() - 1);
  result.positions.assign(cloud.positions.begin(), cloud.positions.end() - 1);
  EXPECT_THROW(demnerf::vtk_export::writeParticlesVtu(scratch("short.vtu").string(), cloud, result), core::Error);
}

}  // namespace
