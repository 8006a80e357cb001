// dem_node's ~export_dir writer without a master: one numbered .vtu per solve, read back by VTK,
// and a folder that cannot be used is reported, never thrown.

#include <gtest/gtest.h>
#include <unistd.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkUnstructuredGrid.h>
#include <vtkXMLUnstructuredGridReader.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "demnerf/mechanics/box_particles.hpp"
#include "nodes/dem/solution_export.hpp"

namespace fs = std::filesystem;
namespace dm = demnerf::mechanics;
using dem_nerf::SolutionExport;

namespace {

fs::path scratchFolder() {
  const fs::path dir = fs::temp_directory_path() / ("demnerf_solution_export_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  return dir;
}

/// A made-up answer on a small box: u = 0.01 X, von Mises = 1 + i (only the bookkeeping is tested
/// here; test_vtk_export checks real solves).
dm::SimulationOutcome outcomeOn(const demnerf::core::ParticleCloud& cloud) {
  dm::SimulationOutcome outcome;
  outcome.field.resize(cloud.size());
  outcome.field.positions = cloud.positions;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    outcome.field.displacements[i] = 0.01 * cloud.positions[i];
    outcome.field.von_mises[i] = 1.0 + static_cast<double>(i);
  }
  return outcome;
}

TEST(SolutionExport, EachSolveGetsTheNextNumberedFile) {
  const demnerf::core::ParticleCloud cloud =
      dm::makeBoxParticles(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0.1, 0.02, 0.02), Eigen::Vector3i(5, 2, 2));
  const fs::path folder = scratchFolder() / "nested";  // created on the first write
  SolutionExport exporter(folder.string());
  ASSERT_TRUE(exporter.enabled());
  for (int n = 1; n <= 2; ++n) {
    const std::string expected = (folder / (n == 1 ? "solve_0001.vtu" : "solve_0002.vtu")).string();
    EXPECT_EQ(exporter.nextPath(), expected);
    const SolutionExport::Report report = exporter.write(cloud, outcomeOn(cloud));
    EXPECT_EQ(report.error, "");
    EXPECT_EQ(report.note, ", written " + expected);
    ASSERT_TRUE(fs::exists(expected));
  }
  vtkNew<vtkXMLUnstructuredGridReader> reader;
  reader->SetFileName((folder / "solve_0002.vtu").c_str());
  reader->Update();
  ASSERT_EQ(reader->GetErrorCode(), 0u);
  vtkUnstructuredGrid* grid = reader->GetOutput();
  ASSERT_EQ(grid->GetNumberOfPoints(), static_cast<vtkIdType>(cloud.size()));
  ASSERT_NE(grid->GetPointData()->GetArray("von_mises"), nullptr);
  EXPECT_EQ(grid->GetPointData()->GetArray("von_mises")->GetComponent(3, 0), 4.0);
  fs::remove_all(folder.parent_path());
}

TEST(SolutionExport, AnUnusableFolderIsReportedNotThrown) {
  const demnerf::core::ParticleCloud cloud =
      dm::makeBoxParticles(Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0.1, 0.02, 0.02), Eigen::Vector3i(2, 1, 1));
  const fs::path base = scratchFolder();
  fs::create_directories(base);
  const fs::path file = base / "a_file";
  std::ofstream(file) << "not a folder";
  SolutionExport exporter((file / "exports").string());  // a folder below a regular file
  SolutionExport::Report report;
  EXPECT_NO_THROW(report = exporter.write(cloud, outcomeOn(cloud)));
  EXPECT_EQ(report.note, "");
  EXPECT_NE(report.error.find(file.string()), std::string::npos) << report.error;
  // A failed write leaves no gap in the numbering.
  EXPECT_EQ(exporter.nextPath(), (file / "exports" / "solve_0001.vtu").string());
  // A result that does not belong to the cloud is refused with the reason, not thrown either.
  SolutionExport fine((base / "ok").string());
  dm::SimulationOutcome wrong = outcomeOn(cloud);
  wrong.field.resize(1);
  report = fine.write(cloud, wrong);
  EXPECT_NE(report.error.find("solution not exported"), std::string::npos) << report.error;
  // Off: nothing written, nothing said.
  report = SolutionExport("").write(cloud, outcomeOn(cloud));
  EXPECT_EQ(report.note + report.error, "");
  fs::remove_all(base);
}

}  // namespace
