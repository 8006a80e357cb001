#include "mechanics_matrix_report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "demnerf/core/error.hpp"

namespace demnerf::bench {
namespace {

std::string fixed(double value, int digits) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*f", digits, value);
  return text;
}

// Lengths in the scenario's units (metres, or Beam3D's unit length): 4 significant digits.
std::string length(double value) {
  char text[64];
  std::snprintf(text, sizeof text, "%.4g", value);
  return text;
}

std::string percent(double fraction) {
  const double p = 100 * fraction;
  return fixed(p, std::abs(p) < 10 ? 2 : 1) + " %";
}

// CSV fields: quotes doubled, the whole field quoted when it holds a comma, quote or newline.
std::string csvField(const std::string& text) {
  if (text.find_first_of(",\"\n") == std::string::npos) return text;
  std::string out = "\"";
  for (char c : text) out += c == '"' ? std::string("\"\"") : std::string(1, c == '\n' ? ' ' : c);
  return out + "\"";
}

// Markdown cells must not contain '|' or newlines.
std::string markdownText(std::string text, std::size_t max_length = 90) {
  std::replace(text.begin(), text.end(), '|', '/');
  std::replace(text.begin(), text.end(), '\n', ' ');
  if (text.size() > max_length) text = text.substr(0, max_length - 3) + "...";
  return text;
}

const MatrixCell* findCell(const MatrixRow& row, const std::string& solver) {
  for (const MatrixCell& cell : row.cells)
    if (cell.solver == solver) return &cell;
  return nullptr;
}

std::string rowLabel(const MatrixRow& row) {
  return row.scenario + " / " + row.source + " / " + row.sampler + " / h=1/" + std::to_string(row.spacing_divisor);
}

// Green at <= 1 % rel. L2 through yellow (5 %) to red at >= 30 %, on a log scale (BGR).
cv::Scalar errorColour(double rel_l2) {
  const double t = std::clamp((std::log10(std::max(rel_l2, 1e-6)) + 2.0) / (std::log10(0.3) + 2.0), 0.0, 1.0);
  const cv::Vec3d green(90, 200, 90), yellow(80, 225, 245), red(80, 80, 230);
  const cv::Vec3d c = t < 0.47 ? green + (yellow - green) * (t / 0.47) : yellow + (red - yellow) * ((t - 0.47) / 0.53);
  return cv::Scalar(c[0], c[1], c[2]);
}

}  // namespace

void writeCsv(const MatrixReport& report, const std::string& path) {
  std::ofstream out(path);
  if (!out) throw core::Error("cannot write " + path);
  out << "scenario,source,sampler,spacing_divisor,spacing_m,particles,solver,converged,failure,reason,seconds,energy_J,"
         "reference_energy_J,energy_error,rel_l2,max_error_m,max_error_rel,reference_max_u_m\n";
  for (const MatrixRow& row : report.rows) {
    const std::string head = row.scenario + "," + row.source + "," + row.sampler + "," +
                             std::to_string(row.spacing_divisor) + "," + fixed(row.spacing, 6) + "," +
                             std::to_string(row.particles) + ",";
    if (!row.cloud_error.empty()) {
      out << head << "sampler,0,sampling," << csvField(row.cloud_error) << ",,,,,,,,\n";
      continue;
    }
    for (const MatrixCell& c : row.cells) {
      out << head << c.solver << "," << (c.converged ? 1 : 0) << "," << c.failure << "," << csvField(c.reason) << ","
          << fixed(c.seconds, 3) << "," << c.energy << "," << row.reference_energy << ",";
      if (c.has_error)
        out << c.energy_error << "," << c.rel_l2 << "," << c.max_error << "," << c.max_error_rel;
      else
        out << ",,,";
      out << "," << row.reference_max_u << "\n";
    }
  }
  for (const ConvergenceRow& r : report.convergence) {
    out << r.scenario << "," << r.source << ",mesh_convergence,0," << fixed(r.fine_cell, 6) << "," << r.fine_dofs
        << ",fem_tet10_h" << fixed(r.coarse_cell, 6) << "_vs_h" << fixed(r.fine_cell, 6) << ","
        << (r.rel_l2 >= 0 && r.rel_l2 < 0.005 ? 1 : 0) << "," << (r.error.empty() ? "" : "error") << ","
        << csvField(r.error.empty() ? (r.sanity_ok ? std::string() : kSanityFailed) + r.sanity : r.error) << ","
        << fixed(r.fine_seconds + r.coarse_seconds, 3) << ","
        << r.coarse_energy << "," << r.fine_energy << ","
        << (r.fine_energy != 0 ? (r.coarse_energy - r.fine_energy) / std::abs(r.fine_energy) : 0.0) << ","
        << r.rel_l2 << ",,,\n";
  }
}

std::string markdown(const MatrixReport& report) {
  std::ostringstream md;
  md << "# Solver matrix" << (report.partial ? " (PARTIAL run)" : "") << "\n\n";
  md << "`" << report.title << "`\n\n";
  md << "Each cell: rel. L2 error of u against the reference FEM (TET10 on a CGAL Mesh_3 mesh of the same surface, "
        "at the same particles), wall seconds, energy error against the reference's energy; or the failure and its "
        "reason. h = smallest body dimension / divisor (in the scenario's length unit: metres, Beam3D's unit "
        "length). A converged cell marked \"warned: stiff\" came with the solver's warning that the particles are too "
        "sparse for the grid their body or its rough surface needs (`demnerf simulate` prints it).\n\n";
  md << "| scenario | source | sampler | h | particles |";
  for (const std::string& s : report.solvers) md << " " << s << " |";
  md << "\n|---|---|---|---|---|";
  for (std::size_t i = 0; i < report.solvers.size(); ++i) md << "---|";
  md << "\n";
  for (const MatrixRow& row : report.rows) {
    md << "| " << row.scenario << " | " << row.source << " | " << row.sampler << " | 1/" << row.spacing_divisor << " ("
       << length(row.spacing) << ") | " << row.particles << " |";
    for (const std::string& s : report.solvers) {
      const MatrixCell* c = findCell(row, s);
      if (!row.cloud_error.empty()) {
        md << " sampler failed: " << markdownText(row.cloud_error, 60) << " |";
      } else if (!c) {
        md << " - |";
      } else if (!c->converged) {
        md << " **FAIL " << c->failure << "** " << fixed(c->seconds, 1) << " s: " << markdownText(c->reason, 70) << " |";
      } else if (!c->has_error) {
        md << " (no reference) " << fixed(c->seconds, 1) << " s, E " << c->energy << " |";
      } else {
        md << " " << percent(c->rel_l2) << ", " << fixed(c->seconds, 1) << " s, E " << (c->energy_error >= 0 ? "+" : "")
           << percent(c->energy_error) << (c->reason.empty() ? "" : ", warned: stiff") << " |";
      }
    }
    md << "\n";
  }
  md << "\n## Reference FEM: mesh convergence and sanity\n\n";
  md << "| scenario | source | fine h (dofs, s) | coarse h (dofs, s) | coarse vs fine rel. L2 | converged < 0.5 % | "
        "energy (fine) | sanity of the fine solution |\n|---|---|---|---|---|---|---|---|\n";
  for (const ConvergenceRow& r : report.convergence) {
    // Rows read back from a CSV (mechanics_matrix_merge) know only the sum of both solves' seconds.
    const std::string coarse_solve =
        r.coarse_dofs > 0 ? " (" + std::to_string(r.coarse_dofs) + ", " + fixed(r.coarse_seconds, 1) + " s)" : "";
    const std::string fine_seconds = r.coarse_dofs > 0 ? "" : " both";
    md << "| " << r.scenario << " | " << r.source << " | " << length(r.fine_cell) << " (" << r.fine_dofs << ", "
       << fixed(r.fine_seconds, 1) << " s" << fine_seconds << ") | " << length(r.coarse_cell) << coarse_solve << " | ";
    if (!r.error.empty()) {
      md << "failed: " << markdownText(r.error) << " | **no** | | |\n";
      continue;
    }
    md << (r.rel_l2 >= 0 ? percent(r.rel_l2) : "-") << " | "
       << (r.rel_l2 >= 0 && r.rel_l2 < 0.005 ? "yes" : "**NO: the reference is not converged to 0.5 %**") << " | "
       << r.fine_energy << " | " << (r.sanity_ok ? "" : "**CHECK FAILED** ") << markdownText(r.sanity, 140) << " |\n";
  }
  return md.str();
}

void writeHeatMap(const MatrixReport& report, const std::string& path) {
  const int label_w = 430, cell_w = 200, row_h = 24, head_h = 56;
  const int rows = static_cast<int>(report.rows.size()), cols = static_cast<int>(report.solvers.size());
  cv::Mat image(head_h + std::max(rows, 1) * row_h + 30, label_w + std::max(cols, 1) * cell_w, CV_8UC3,
                cv::Scalar(255, 255, 255));
  const int font = cv::FONT_HERSHEY_SIMPLEX;
  const cv::Scalar black(0, 0, 0);
  cv::putText(image, std::string("rel. L2 of u vs FEM TET10 reference") + (report.partial ? "  (PARTIAL)" : ""),
              cv::Point(8, 20), font, 0.55, black, 1, cv::LINE_AA);
  for (int j = 0; j < cols; ++j)
    cv::putText(image, report.solvers[j], cv::Point(label_w + j * cell_w + 8, head_h - 8), font, 0.5, black, 1,
                cv::LINE_AA);
  for (int i = 0; i < rows; ++i) {
    const MatrixRow& row = report.rows[i];
    const int y = head_h + i * row_h;
    cv::putText(image, rowLabel(row) + " (" + std::to_string(row.particles) + ")", cv::Point(6, y + 17), font, 0.42,
                black, 1, cv::LINE_AA);
    for (int j = 0; j < cols; ++j) {
      const cv::Rect box(label_w + j * cell_w, y, cell_w - 2, row_h - 2);
      const MatrixCell* c = findCell(row, report.solvers[j]);
      std::string text;
      cv::Scalar fill(235, 235, 235), ink = black;
      if (!row.cloud_error.empty()) {
        fill = cv::Scalar(60, 60, 60), ink = cv::Scalar(255, 255, 255), text = "sampler failed";
      } else if (!c) {
        text = "-";
      } else if (!c->converged) {
        fill = cv::Scalar(60, 60, 60), ink = cv::Scalar(255, 255, 255);
        text = "FAIL " + c->failure + " " + fixed(c->seconds, 0) + "s";
      } else if (!c->has_error) {
        text = "no ref " + fixed(c->seconds, 1) + "s";
      } else {
        fill = errorColour(c->rel_l2);
        text = percent(c->rel_l2) + "  " + fixed(c->seconds, 1) + "s" + (c->reason.empty() ? "" : " *");
      }
      cv::rectangle(image, box, fill, cv::FILLED);
      cv::putText(image, text, cv::Point(box.x + 6, box.y + 16), font, 0.42, ink, 1, cv::LINE_AA);
    }
  }
  cv::putText(image, "green <= 1 %, yellow ~5 %, red >= 30 %; dark: failed (cause and seconds); *: warned stiff",
              cv::Point(8, head_h + rows * row_h + 20), font, 0.45, black, 1, cv::LINE_AA);
  if (!cv::imwrite(path, image)) throw core::Error("cannot write " + path);
}

}  // namespace demnerf::bench
