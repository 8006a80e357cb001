#include "demnerf/vtk_export/vtu_writer.hpp"

#include <vtkCellArray.h>
#include <vtkCellData.h>
#include <vtkCellType.h>
#include <vtkDoubleArray.h>
#include <vtkErrorCode.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkSmartPointer.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLUnstructuredGridWriter.h>

#include <cmath>
#include <filesystem>
#include <system_error>

#include "demnerf/core/error.hpp"

namespace demnerf::vtk_export {
namespace {

namespace fs = std::filesystem;
using core::Error;

vtkSmartPointer<vtkPoints> makePoints(const std::vector<Eigen::Vector3d>& positions) {
  auto points = vtkSmartPointer<vtkPoints>::New();
  points->SetDataTypeToDouble();  // metres at double precision: a read-back equals the solver's numbers
  points->SetNumberOfPoints(static_cast<vtkIdType>(positions.size()));
  for (std::size_t i = 0; i < positions.size(); ++i)
    points->SetPoint(static_cast<vtkIdType>(i), positions[i].x(), positions[i].y(), positions[i].z());
  return points;
}

vtkSmartPointer<vtkDoubleArray> vectorArray(const char* name, const std::vector<Eigen::Vector3d>& values) {
  auto array = vtkSmartPointer<vtkDoubleArray>::New();
  array->SetName(name);
  array->SetNumberOfComponents(3);
  array->SetNumberOfTuples(static_cast<vtkIdType>(values.size()));
  for (std::size_t i = 0; i < values.size(); ++i)
    array->SetTuple3(static_cast<vtkIdType>(i), values[i].x(), values[i].y(), values[i].z());
  return array;
}

vtkSmartPointer<vtkDoubleArray> scalarArray(const char* name, const std::vector<double>& values) {
  auto array = vtkSmartPointer<vtkDoubleArray>::New();
  array->SetName(name);
  array->SetNumberOfComponents(1);
  array->SetNumberOfTuples(static_cast<vtkIdType>(values.size()));
  for (std::size_t i = 0; i < values.size(); ++i) array->SetValue(static_cast<vtkIdType>(i), values[i]);
  return array;
}

/// The three point fields; displacement is the active vector (Warp By Vector picks it) and
/// von Mises the active scalar (the colouring ParaView starts with).
void addPointFields(vtkUnstructuredGrid& grid, const std::vector<Eigen::Vector3d>& displacement,
                    const std::vector<double>& von_mises, const std::vector<double>& volume) {
  const auto u = vectorArray(kDisplacement, displacement);
  const auto s = scalarArray(kVonMises, von_mises);
  const auto v = scalarArray(kVolume, volume);
  grid.GetPointData()->AddArray(u);
  grid.GetPointData()->AddArray(s);
  grid.GetPointData()->AddArray(v);
  grid.GetPointData()->SetActiveVectors(kDisplacement);
  grid.GetPointData()->SetActiveScalars(kVonMises);
}

/// Writes through a temporary file renamed into place, so a reader polling the folder (ParaView,
/// a script) never opens a half-written solution.
void write(vtkUnstructuredGrid& grid, const std::string& path) {
  if (path.empty()) throw Error("vtu export: no file name given");
  const fs::path target(path);
  const fs::path folder = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::is_directory(folder, ec))
    throw Error("vtu export: cannot write " + path + ": the folder " + folder.string() + " does not exist");
  const std::string temporary = path + ".part";
  vtkNew<vtkXMLUnstructuredGridWriter> writer;
  writer->SetFileName(temporary.c_str());
  writer->SetInputData(&grid);
  writer->SetDataModeToAppended();  // raw binary after the XML header: smallest and fastest to read
  writer->EncodeAppendedDataOff();
  const int ok = writer->Write();
  const unsigned long code = writer->GetErrorCode();
  if (ok != 1 || code != vtkErrorCode::NoError) {
    fs::remove(temporary, ec);
    const char* reason = vtkErrorCode::GetStringFromErrorCode(code);
    throw Error("vtu export: cannot write " + path + " (" + (reason && *reason ? reason : "VTK writer failed") +
                "; is the folder writable and the disk not full?)");
  }
  fs::rename(temporary, target, ec);
  if (ec) {
    fs::remove(temporary, ec);
    throw Error("vtu export: cannot move the written file onto " + path + ": " + ec.message());
  }
}

}  // namespace

void writeParticlesVtu(const std::string& path, const core::ParticleCloud& cloud, const core::ResultField& result) {
  result.validate();
  if (result.size() != cloud.size() || cloud.volumes.size() != cloud.size())
    throw Error("vtu export: the result has " + std::to_string(result.size()) + " rows but the particle cloud " +
                std::to_string(cloud.size()) + " particles (a result belongs to the cloud it was solved on)");
  vtkNew<vtkUnstructuredGrid> grid;
  grid->SetPoints(makePoints(result.positions));
  // One vertex cell per particle: without cells ParaView's render views draw nothing.
  vtkNew<vtkCellArray> cells;
  cells->AllocateExact(static_cast<vtkIdType>(result.size()), static_cast<vtkIdType>(result.size()));
  for (std::size_t i = 0; i < result.size(); ++i) {
    const vtkIdType id = static_cast<vtkIdType>(i);
    cells->InsertNextCell(1, &id);
  }
  grid->SetCells(VTK_VERTEX, cells);
  addPointFields(*grid, result.displacements, result.von_mises, cloud.volumes);
  write(*grid, path);
}

void writeTetMeshVtu(const std::string& path, const mechanics::TetMesh& mesh,
                     const std::vector<Eigen::Vector3d>& displacement, const std::vector<double>& von_mises) {
  if (displacement.size() != mesh.nodes.size() || von_mises.size() != mesh.nodes.size())
    throw Error("vtu export: the mesh has " + std::to_string(mesh.nodes.size()) + " nodes but the solution " +
                std::to_string(displacement.size()) + " displacements and " + std::to_string(von_mises.size()) +
                " stresses");
  if (mesh.order != 1 && mesh.order != 2) throw Error("vtu export: tetrahedra of order 1 or 2 only");
  const int per_element = mesh.nodesPerElement();
  const int node_count = static_cast<int>(mesh.nodes.size());
  std::vector<double> nodal_volume(mesh.nodes.size(), 0.0);
  std::vector<double> element_volume(mesh.elements.size(), 0.0);
  vtkNew<vtkCellArray> cells;
  cells->AllocateExact(static_cast<vtkIdType>(mesh.elements.size()),
                       static_cast<vtkIdType>(mesh.elements.size() * per_element));
  for (std::size_t e = 0; e < mesh.elements.size(); ++e) {
    const auto& element = mesh.elements[e];
    vtkIdType ids[10];
    for (int a = 0; a < per_element; ++a) {
      if (element[a] < 0 || element[a] >= node_count)
        throw Error("vtu export: element " + std::to_string(e) + " names node " + std::to_string(element[a]) +
                    " of " + std::to_string(node_count));
      ids[a] = element[a];
    }
    // Straight-sided elements: the corners give the volume. A lumped share per node keeps the
    // point field "volume" summing to the body's volume, as the particles' does.
    double volume = 0.0;
    mechanics::barycentricGradients({mesh.nodes[element[0]], mesh.nodes[element[1]], mesh.nodes[element[2]],
                                     mesh.nodes[element[3]]},
                                    &volume);
    volume = std::abs(volume);
    element_volume[e] = volume;
    for (int a = 0; a < per_element; ++a) nodal_volume[element[a]] += volume / per_element;
    cells->InsertNextCell(per_element, ids);
  }
  vtkNew<vtkUnstructuredGrid> grid;
  grid->SetPoints(makePoints(mesh.nodes));
  // VTK's quadratic tetra lists the edge nodes (0,1) (1,2) (2,0) (0,3) (1,3) (2,3): the mesh's order.
  grid->SetCells(mesh.order == 1 ? VTK_TETRA : VTK_QUADRATIC_TETRA, cells);
  addPointFields(*grid, displacement, von_mises, nodal_volume);
  const auto cell_volume = scalarArray("element_volume", element_volume);
  grid->GetCellData()->AddArray(cell_volume);
  write(*grid, path);
}

}  // namespace demnerf::vtk_export
