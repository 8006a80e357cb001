// mechanics_matrix_merge: one solver-matrix report (CSV, Markdown, heat map) from the CSVs of
// several mechanics_matrix runs, e.g. a column per solver run at different times.
//
//   mechanics_matrix_merge out=DIR [title=TEXT] [solvers=fem,dem,...] a.csv b.csv ...
//
// Rows are keyed by scenario, source, sampler and spacing; a solver's cell in a later CSV replaces
// the same solver's cell of that cloud in an earlier one (and the later reference energy the
// earlier), and a later mesh-convergence row the earlier one of its scenario and source: list the
// runs against the finest references last. Columns keep the order of solvers=, else of first
// appearance; rows are grouped by scenario, source and sampler, spacings coarse to fine. The
// report is always titled PARTIAL: a merge does not prove every cell was run.

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <string>
#include <tuple>
#include <vector>

#include "demnerf/core/error.hpp"
#include "mechanics_matrix_report.hpp"

namespace bench = demnerf::bench;

namespace {

void addSolver(bench::MatrixReport& report, const std::string& solver) {
  for (const std::string& s : report.solvers)
    if (s == solver) return;
  report.solvers.push_back(solver);
}

void mergeRow(bench::MatrixReport& into, const bench::MatrixRow& row) {
  for (bench::MatrixRow& mine : into.rows) {
    if (mine.scenario != row.scenario || mine.source != row.source || mine.sampler != row.sampler ||
        mine.spacing_divisor != row.spacing_divisor)
      continue;
    for (const bench::MatrixCell& cell : row.cells) {
      bool replaced = false;
      for (bench::MatrixCell& old : mine.cells)
        if (old.solver == cell.solver) old = cell, replaced = true;
      if (!replaced) mine.cells.push_back(cell);
      addSolver(into, cell.solver);
    }
    if (!row.cloud_error.empty()) mine.cloud_error = row.cloud_error;
    // A later run may use a finer reference: its cells were measured against it.
    mine.reference_energy = row.reference_energy, mine.reference_max_u = row.reference_max_u;
    return;
  }
  into.rows.push_back(row);
  for (const bench::MatrixCell& cell : row.cells) addSolver(into, cell.solver);
}

void mergeConvergence(bench::MatrixReport& into, const bench::ConvergenceRow& row) {
  for (bench::ConvergenceRow& mine : into.convergence)
    if (mine.scenario == row.scenario && mine.source == row.source) return void(mine = row);
  into.convergence.push_back(row);
}

// Rows grouped as mechanics_matrix writes them: scenario, source and sampler in the order they
// first appear, spacings coarse to fine.
void sortRows(bench::MatrixReport& report) {
  std::vector<std::string> order;
  const auto rank = [&order](const std::string& name) {
    const auto at = std::find(order.begin(), order.end(), name);
    if (at != order.end()) return static_cast<int>(at - order.begin());
    order.push_back(name);
    return static_cast<int>(order.size()) - 1;
  };
  for (const bench::MatrixRow& row : report.rows) rank(row.scenario), rank(row.source), rank(row.sampler);
  std::stable_sort(report.rows.begin(), report.rows.end(), [&](const bench::MatrixRow& a, const bench::MatrixRow& b) {
    return std::make_tuple(rank(a.scenario), rank(a.source), rank(a.sampler), a.spacing_divisor) <
           std::make_tuple(rank(b.scenario), rank(b.source), rank(b.sampler), b.spacing_divisor);
  });
}

}  // namespace

int main(int argc, char** argv) {
  try {
    std::string out, title = "mechanics_matrix_merge", solvers;
    std::vector<std::string> inputs;
    for (int i = 1; i < argc; ++i) {
      const std::string arg = argv[i];
      if (arg.rfind("out=", 0) == 0) out = arg.substr(4);
      else if (arg.rfind("title=", 0) == 0) title = arg.substr(6);
      else if (arg.rfind("solvers=", 0) == 0) solvers = arg.substr(8);
      else inputs.push_back(arg);
    }
    if (out.empty() || inputs.empty())
      throw demnerf::core::Error("usage: mechanics_matrix_merge out=DIR [title=TEXT] [solvers=a,b] FILE.csv ...");
    bench::MatrixReport report;
    report.title = title;
    report.partial = true;
    report.solvers = bench::splitList(solvers);
    for (const std::string& input : inputs) {
      const bench::MatrixReport part = bench::readCsv(input);
      for (const bench::MatrixRow& row : part.rows) mergeRow(report, row);
      for (const bench::ConvergenceRow& row : part.convergence) mergeConvergence(report, row);
    }
    sortRows(report);
    std::filesystem::create_directories(out);
    bench::writeCsv(report, out + "/mechanics_matrix.csv");
    std::ofstream(out + "/mechanics_matrix.md") << bench::markdown(report);
    bench::writeHeatMap(report, out + "/mechanics_matrix.png");
    std::cout << report.rows.size() << " clouds x " << report.solvers.size() << " solvers from " << inputs.size()
              << " CSVs -> " << out << "/mechanics_matrix.{csv,md,png}\n";
    return 0;
  } catch (const std::exception& error) {
    std::cerr << "mechanics_matrix_merge: " << error.what() << "\n";
    return 1;
  }
}
