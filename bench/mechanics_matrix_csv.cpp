// Reading the solver matrix's CSV back (mechanics_matrix_merge), so that columns run at different
// times, on different branches or against different references can be put into one report.

#include <fstream>
#include <string>
#include <vector>

#include "demnerf/core/error.hpp"
#include "mechanics_matrix_report.hpp"

namespace demnerf::bench {
namespace {

// One CSV line's fields, as csvField quotes them (doubled quotes inside a quoted field).
std::vector<std::string> splitCsvLine(const std::string& line) {
  std::vector<std::string> fields(1);
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted && c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
      fields.back() += '"', ++i;
    } else if (c == '"') {
      quoted = !quoted;
    } else if (c == ',' && !quoted) {
      fields.emplace_back();
    } else {
      fields.back() += c;
    }
  }
  return fields;
}

double number(const std::string& text) { return text.empty() ? 0.0 : std::stod(text); }

// "fem_tet10_h<coarse>_vs_h<fine>": the coarse mesh's cell.
double coarseCell(const std::string& solver) {
  const std::size_t at = solver.find("_h"), end = solver.find("_vs_h");
  if (at == std::string::npos || end == std::string::npos) throw core::Error("no mesh sizes in '" + solver + "'");
  return std::stod(solver.substr(at + 2, end - at - 2));
}

ConvergenceRow convergenceRow(const std::vector<std::string>& f) {
  ConvergenceRow r;
  r.scenario = f[0], r.source = f[1];
  r.fine_cell = number(f[4]), r.fine_dofs = static_cast<int>(number(f[5]));
  r.coarse_cell = coarseCell(f[6]);
  if (f[8] == "error") {
    r.error = f[9];
  } else {
    r.sanity_ok = f[9].rfind(kSanityFailed, 0) != 0;
    r.sanity = r.sanity_ok ? f[9] : f[9].substr(kSanityFailed.size());
  }
  r.fine_seconds = number(f[10]);
  r.coarse_energy = number(f[11]), r.fine_energy = number(f[12]);
  r.rel_l2 = f[14].empty() ? -1.0 : number(f[14]);
  return r;
}

MatrixCell cell(const std::vector<std::string>& f) {
  MatrixCell c;
  c.solver = f[6];
  c.converged = f[7] == "1";
  c.failure = f[8], c.reason = f[9];
  c.seconds = number(f[10]), c.energy = number(f[11]);
  c.has_error = !f[14].empty();
  c.energy_error = number(f[13]), c.rel_l2 = number(f[14]);
  c.max_error = number(f[15]), c.max_error_rel = number(f[16]);
  return c;
}

// The row of this line's cloud, appended when it is the first line of that cloud.
MatrixRow& rowOf(MatrixReport& report, const std::vector<std::string>& f) {
  const int divisor = static_cast<int>(number(f[3]));
  for (MatrixRow& row : report.rows)
    if (row.scenario == f[0] && row.source == f[1] && row.sampler == f[2] && row.spacing_divisor == divisor) return row;
  MatrixRow row;
  row.scenario = f[0], row.source = f[1], row.sampler = f[2], row.spacing_divisor = divisor;
  row.spacing = number(f[4]);
  row.particles = static_cast<std::size_t>(number(f[5]));
  row.reference_energy = number(f[12]), row.reference_max_u = number(f[17]);
  report.rows.push_back(row);
  return report.rows.back();
}

}  // namespace

MatrixReport readCsv(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw core::Error("cannot read " + path);
  MatrixReport report;
  std::string line;
  std::getline(in, line);  // the header
  for (int number_of_line = 2; std::getline(in, line); ++number_of_line) {
    if (line.empty()) continue;
    const std::vector<std::string> f = splitCsvLine(line);
    try {
      if (f.size() != 18) throw core::Error(std::to_string(f.size()) + " fields where the matrix writes 18");
      if (f[2] == "mesh_convergence") {
        report.convergence.push_back(convergenceRow(f));
      } else if (f[6] == "sampler") {
        rowOf(report, f).cloud_error = f[9];
      } else {
        rowOf(report, f).cells.push_back(cell(f));
      }
    } catch (const std::exception& error) {
      throw core::Error(path + " line " + std::to_string(number_of_line) + ": " + error.what());
    }
  }
  return report;
}

}  // namespace demnerf::bench
