#include "demnerf/mechanics/solver_config_yaml.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <fstream>
#include <limits>
#include <sstream>
#include <utility>

#include "config_table.hpp"
#include "demnerf/core/error.hpp"

namespace demnerf::mechanics {
namespace {

using core::Error;
using namespace config_table;

std::vector<Field> femFields(FemConfig& c) {
  const std::string s = "fem";
  const int many = std::numeric_limits<int>::max();
  using L = FemConfig::LinearSolver;
  using O = FemConfig::Ordering;
  return {
      choice<L>(s, "linear_solver", c.linear_solver, {{"ldlt", L::kLDLT}, {"cg", L::kConjugateGradient}},
                "sparse linear solver of each Newton step"),
      choice<O>(s, "ordering", c.ordering, {{"amd", O::kAmd}, {"nested_dissection", O::kNestedDissection}},
                "fill-reducing order of the LDLT"),
      integer(s, "max_newton_iterations", c.max_newton_iterations, 1, many, "Newton iterations per load step"),
      integer(s, "load_steps", c.load_steps, 0, many, "load increments (0: the scenario's)"),
      integer(s, "threads", c.threads, 0, many, "assembly threads (0: all cores)"),
      integer(s, "reuse_factorisation_iterations", c.reuse_factorisation_iterations, 0, many,
              "LDLT reused as CG preconditioner until CG needs more (0: refactorise)"),
      number(s, "tolerance", c.tolerance, 0, true, kInf, "|residual| <= this x (|external| + |internal| forces)"),
      number(s, "displacement_tolerance", c.displacement_tolerance, 0, false, kInf,
             "...or the last update below this x |u|"),
      integer(s, "max_step_halvings", c.max_step_halvings, 0, many, "halvings of a failed load step"),
      number(s, "cg_tolerance", c.cg_tolerance, 0, true, kInf, "relative tolerance of the CG solves"),
      flag(s, "verbose", c.verbose, "print Newton iterations"),
  };
}

std::vector<Field> pinnFields(PinnConfig& c) {
  const std::string s = "pinn";
  const int many = std::numeric_limits<int>::max();
  return {
      integer(s, "width", c.width, 1, many, "hidden units per layer"),
      integer(s, "depth", c.depth, 1, many, "hidden layers"),
      choice(s, "activation", c.activation, words({"tanh", "sin", "softplus"}), "MLP activation"),
      number(s, "weight_residual", c.weight_residual, 0, false, kInf, "W_R on the equilibrium residual"),
      number(s, "weight_traction", c.weight_traction, 0, false, kInf, "W_t on the traction residual"),
      number(s, "weight_displacement", c.weight_displacement, 0, false, kInf, "W_u on the displacement residual"),
      integer(s, "adam_iterations", c.adam_iterations, 0, many, "Adam steps per load step"),
      integer(s, "residual_batch", c.residual_batch, 0, many, "residual particles per Adam step (0: all)"),
      flag(s, "jitter", c.jitter, "residual points move within their cell every step"),
      number(s, "adam_learning_rate", c.adam_learning_rate, 0, true, kInf, "Adam's initial learning rate"),
      number(s, "adam_final_rate_ratio", c.adam_final_rate_ratio, 0, true, 1, "learning rate at a step's end / start"),
      integer(s, "rescale_every", c.rescale_every, 0, many, "output amplitude line search every N steps (0: never)"),
      integer(s, "rescale_until", c.rescale_until, 0, many, "...during the first N steps"),
      number(s, "displacement_scale", c.displacement_scale, 0, false, kInf, "m per unit output (0: estimated)"),
      integer(s, "lbfgs_iterations", c.lbfgs_iterations, 0, many, "L-BFGS polish per load step (0: off)"),
      integer(s, "lbfgs_history", c.lbfgs_history, 1, many, "L-BFGS history length"),
      integer(s, "load_steps", c.load_steps, 0, many, "load steps (0: the scenario's)"),
      integer(s, "max_halvings", c.max_halvings, 0, many, "load-step halvings after a failed step"),
      integer(s, "threads", c.threads, 0, many, "torch threads (0: 1 below 50k particles, else all cores)"),
      integer(s, "seed", c.seed, std::numeric_limits<int>::min(), many, "random seed"),
      flag(s, "double_precision", c.double_precision, "float64 instead of float32"),
      flag(s, "verbose", c.verbose, "print training details"),
  };
}

std::vector<Field> fields(SimulateOptions& o) {
  std::vector<Field> all = demFields(o.dem);
  auto append = [&all](std::vector<Field> more) {
    for (Field& f : more) all.push_back(std::move(f));
  };
  append(femFields(o.fem));
  append(pinnFields(o.pinn));
  append({number("voxel", "cell", o.voxel.cell, 0, false, kInf,
                 "FEM mesh size in m: hex edge, or CGAL tetrahedron edge (0: automatic)"),
          integer("voxel", "order", o.voxel.order, 1, 2, "FEM elements: 1 TET4, 2 TET10"),
          number("voxel", "elements_across", o.voxel.elements_across, 0, true, kInf,
                 "automatic FEM cell: the body's thickness over this many elements"),
          number("voxel", "max_dofs", o.voxel.max_dofs, 1, false, kInf,
                 "automatic FEM cell: coarsened until the mesh is expected to hold at most this many dofs")});
  using M = SimulateOptions::Mesher;
  append({choice<M>("", "mesher", o.mesher, {{"cgal", M::kCgal}, {"voxel", M::kVoxel}},
                    "how the FEM meshes: cgal follows --mesh or the particles' surface; "
                    "voxel: voxels of --mesh or blocks of particle cells")});
  append({number("control", "time_limit", o.control.time_limit, 0, false, kInf, "s per solve (0: no limit)"),
          number("control", "progress_interval", o.control.progress_interval, 0, false, kInf,
                 "s between progress reports")});
  return all;
}

const std::vector<std::string>& sectionNames() {
  static const std::vector<std::string> names{"dem", "fem", "pinn", "voxel", "control"};
  return names;
}

void readField(const Field& field, const YAML::Node& value, const std::string& source) {
  const std::string name = field.section.empty() ? field.key : field.section + "." + field.key;
  const std::string problem = field.read(value);
  if (!problem.empty()) throw Error(source + ": '" + name + "' " + problem);
}

const Field* findField(const std::vector<Field>& table, const std::string& section, const std::string& key) {
  for (const Field& f : table)
    if (f.section == section && f.key == key) return &f;
  return nullptr;
}

bool isSubsection(const std::vector<Field>& table, const std::string& section) {
  for (const Field& f : table)
    if (f.section == section) return true;
  return false;
}

/// The keys of one section (or of a part of one: "dem.grid"), recursing into the parts.
void readSection(const std::string& name, const YAML::Node& node, const std::vector<Field>& table,
                 const std::string& source) {
  if (node.IsNull()) return;  // "dem:" with nothing under it
  if (!node.IsMap()) throw Error(source + ": section '" + name + "' must be a mapping of keys to values");
  for (const auto& item : node) {
    const std::string key = item.first.as<std::string>();
    if (const Field* found = findField(table, name, key)) {
      readField(*found, item.second, source);
      continue;
    }
    // DemConfig's flat keys of files written before it had parts, read as their new names: a
    // scalar "boundary: penalty" is boundary.kind, a mapping "boundary: {kind: penalty}" the part.
    const std::string renamed = name == "dem" ? renamedDemKey(key) : "";
    const bool part = isSubsection(table, name + "." + key);
    if (part && (renamed.empty() || !item.second.IsScalar())) {
      readSection(name + "." + key, item.second, table, source);
      continue;
    }
    if (!renamed.empty()) {
      const auto dot = renamed.find('.');
      readField(*findField(table, "dem." + renamed.substr(0, dot), renamed.substr(dot + 1)), item.second, source);
      continue;
    }
    throw Error(source + ": unknown key '" + name + "." + key +
                "' (config/solvers.yaml lists every key with its default)");
  }
}

void readSections(const YAML::Node& root, const std::vector<Field>& table, const std::string& source) {
  for (const auto& entry : root) {
    const std::string name = entry.first.as<std::string>();
    bool is_section = false;
    for (const std::string& s : sectionNames()) is_section |= s == name;
    if (is_section) {
      readSection(name, entry.second, table, source);
      continue;
    }
    const Field* top = findField(table, "", name);
    if (!top) throw Error(source + ": unknown key '" + name + "' (known: dem, fem, pinn, voxel, control, mesher)");
    readField(*top, entry.second, source);
  }
}

}  // namespace

DemConfig demConfigForMethod(const std::string& method) {
  if (method == "grid") return DemConfig{};
  if (method == "mlp") return paperDemConfig();
  throw Error("unknown DEM method '" + method + "': use grid (the feature-grid DEM) or mlp (the paper's MLP DEM)");
}

SimulateOptions solverDefaults(const std::string& dem_method, const std::string& config_path) {
  SimulateOptions options;
  options.dem = demConfigForMethod(dem_method);
  return config_path.empty() ? options : loadSolverConfig(config_path, std::move(options));
}

SimulateOptions parseSolverConfig(const std::string& yaml_text, const std::string& source, SimulateOptions base) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw Error(source + ": not valid YAML: " + e.what());
  }
  if (!root || root.IsNull()) return base;
  if (!root.IsMap())
    throw Error(source + ": expected a mapping with sections dem, fem, pinn, voxel, control and the key mesher");
  const std::vector<Field> table = fields(base);
  try {
    readSections(root, table, source);
  } catch (const YAML::Exception& e) {
    throw Error(source + ": " + e.what());
  }
  return base;
}

SimulateOptions loadSolverConfig(const std::string& path, SimulateOptions base) {
  std::ifstream in(path);
  if (!in) throw Error("cannot read solver config '" + path + "'");
  std::stringstream text;
  text << in.rdbuf();
  return parseSolverConfig(text.str(), path, std::move(base));
}

std::string solverConfigYaml(const SimulateOptions& options) {
  SimulateOptions copy = options;
  std::ostringstream out;
  std::string section = "-";
  for (const Field& f : fields(copy)) {
    if (f.section != section) {
      // "dem.grid" is written as "  grid:" under "dem:" (which the "dem" keys opened).
      const auto dot = f.section.find('.');
      if (dot == std::string::npos) out << "\n" << (f.section.empty() ? "" : f.section + ":\n");
      else out << "  " << f.section.substr(dot + 1) << ":\n";
      section = f.section;
    }
    const std::string indent(section.empty() ? 0 : section.find('.') == std::string::npos ? 2 : 4, ' ');
    std::string line = indent + f.key + ": " + f.write();
    line.resize(std::max<std::size_t>(line.size() + 1, 40), ' ');
    out << line << "# " << f.meaning << "\n";
  }
  return out.str();
}

std::vector<std::string> solverConfigKeys() {
  SimulateOptions scratch;
  std::vector<std::string> keys;
  for (const Field& f : fields(scratch)) keys.push_back(f.section.empty() ? f.key : f.section + "." + f.key);
  return keys;
}

}  // namespace demnerf::mechanics
