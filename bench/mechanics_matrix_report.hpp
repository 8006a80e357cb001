#pragma once
// The solver matrix's records and how they are written: a CSV (one line per cell), a Markdown
// table (rows scenario x source x sampler x spacing, a column per solver) and a heat map PNG
// coloured by the displacement error against the reference FEM.

#include <sstream>
#include <string>
#include <vector>

namespace demnerf::bench {

/// "a,b,,c" -> {a, b, c}: the matrix tools' comma lists (scenarios=, solvers=, ...).
inline std::vector<std::string> splitList(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

/// One solver on one particle cloud.
struct MatrixCell {
  std::string solver;
  bool converged = false;
  std::string failure;  ///< SolveFailure name, "error" (core::Error) or "no_reference"; empty when fine
  std::string reason;   ///< what() of the failure; on a converged cell the solver's warning (empty: none)
  double seconds = 0.0;
  double energy = 0.0;
  bool has_error = false;  ///< rel_l2 etc. are set (a converged cell with a reference)
  double rel_l2 = 0.0;
  double max_error = 0.0;      ///< m
  double max_error_rel = 0.0;  ///< of the reference's largest |u|
  double energy_error = 0.0;   ///< (E - E_ref) / |E_ref|
};

/// One particle cloud: scenario x source x sampler x spacing.
struct MatrixRow {
  std::string scenario, source, sampler;
  int spacing_divisor = 0;  ///< spacing = smallest dimension / divisor
  double spacing = 0.0;
  std::size_t particles = 0;
  std::string cloud_error;  ///< the sampler failed (no cells then)
  double reference_energy = 0.0;
  double reference_max_u = 0.0;
  std::vector<MatrixCell> cells;
};

/// The reference FEM of one scenario x source at two mesh sizes.
struct ConvergenceRow {
  std::string scenario, source;
  double fine_cell = 0.0, coarse_cell = 0.0;
  int fine_dofs = 0, coarse_dofs = 0;
  double fine_seconds = 0.0, coarse_seconds = 0.0;
  double fine_energy = 0.0, coarse_energy = 0.0;
  double rel_l2 = -1.0;  ///< coarse vs fine on all particles of the scenario x source; < 0: failed
  std::string error;
  std::string sanity;
  bool sanity_ok = true;
};

struct MatrixReport {
  std::string title;    ///< the command line
  bool partial = false;  ///< a subset of the full matrix (quick run, chosen scenarios, ...)
  std::vector<std::string> solvers;
  std::vector<MatrixRow> rows;
  std::vector<ConvergenceRow> convergence;
};

/// Prefixes the sanity text of a mesh-convergence line in the CSV when the check failed.
inline const std::string kSanityFailed = "CHECK FAILED: ";

void writeCsv(const MatrixReport& report, const std::string& path);
/// The rows and mesh-convergence rows of a CSV that writeCsv wrote (title and solvers left empty;
/// a convergence row's coarse dofs are not in the CSV: 0, its seconds all in fine_seconds).
/// core::Error naming the file and line on a malformed line.
MatrixReport readCsv(const std::string& path);
std::string markdown(const MatrixReport& report);
void writeHeatMap(const MatrixReport& report, const std::string& path);

}  // namespace demnerf::bench
