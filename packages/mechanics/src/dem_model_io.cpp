#include "demnerf/mechanics/dem_model_io.hpp"

#include <cstring>
#include <nlohmann/json.hpp>

#include "demnerf/core/error.hpp"
#include "demnerf/core/model_container.hpp"
#include "demnerf/core/scenario.hpp"

namespace demnerf::mechanics {
namespace {

constexpr core::ModelMagic kMagic = {'D', 'E', 'M', 'N', 'E', 'R', 'F', 'D'};
constexpr const char* kWhat = "DEM model";

// The model file keeps DemConfig's flat key names ("grid_cell" for config.grid.cell): the format
// did not change when the struct grew parts, so every model saved before still loads.
nlohmann::json toJson(const DemConfig& c) {
  return {{"width", c.network.width},
          {"depth", c.network.depth},
          {"activation", c.network.activation},
          {"boundary", c.boundary.kind == DemConfig::Boundary::kExact ? "exact" : "penalty"},
          {"penalty_weight", c.boundary.penalty_weight},
          {"adam_iterations", c.adam.iterations},
          {"adam_learning_rate", c.adam.learning_rate},
          {"adam_final_rate_ratio", c.adam.final_rate_ratio},
          {"rescale_every", c.adam.rescale_every},
          {"rescale_until", c.adam.rescale_until},
          {"output_newton", c.output_newton.enabled},
          {"newton_every", c.output_newton.every},
          {"newton_iterations", c.output_newton.iterations},
          {"grid_cell", c.grid.cell},
          {"grid_spacings", c.grid.spacings},
          {"grid_degree", c.grid.degree},
          {"grid_newton_iterations", c.grid.newton_iterations},
          {"grid_refine_band", c.grid.refine_band},
          {"grid_surface_share", c.grid.surface_share},
          {"grid_quadrature", c.grid.quadrature == DemConfig::GridQuadrature::kCells ? "cells" : "particles"},
          {"grid_gauss_points", c.grid.gauss_points},
          {"grid_boundary_levels", c.grid.boundary_levels},
          {"grid_body_cells", c.grid.body_cells},
          {"grid_extension_fill", c.grid.extension_fill},
          {"load_steps", c.load_steps},
          {"jitter", c.adam.jitter},
          {"jitter_band", c.adam.jitter_band},
          {"lbfgs_iterations", c.lbfgs.iterations},
          {"lbfgs_history", c.lbfgs.history},
          {"polish_max_energy_drop", c.lbfgs.max_energy_drop},
          {"polish_max_growth", c.lbfgs.max_growth},
          {"tolerance", c.lbfgs.tolerance},
          {"max_halvings", c.max_halvings},
          {"parametric", c.parametric.enabled},
          {"load_range_min", c.parametric.load_range_min},
          {"load_range_max", c.parametric.load_range_max},
          {"parametric_samples", c.parametric.samples},
          {"seed", c.network.seed},
          {"double_precision", c.network.double_precision},
          {"thickness_inputs", c.network.thickness_inputs},
          {"surface_loads", c.surface_loads}};
}

// Threads, verbosity and the allocator switch belong to the machine that loads the model.
DemConfig configFromJson(const nlohmann::json& j) {
  DemConfig c;
  c.network.width = j.at("width");
  c.network.depth = j.at("depth");
  c.network.activation = j.at("activation");
  c.boundary.kind = j.at("boundary") == "penalty" ? DemConfig::Boundary::kPenalty : DemConfig::Boundary::kExact;
  c.boundary.penalty_weight = j.at("penalty_weight");
  c.adam.iterations = j.at("adam_iterations");
  c.adam.learning_rate = j.at("adam_learning_rate");
  c.adam.final_rate_ratio = j.at("adam_final_rate_ratio");
  c.adam.rescale_every = j.at("rescale_every");
  c.adam.rescale_until = j.at("rescale_until");
  c.output_newton.enabled = j.at("output_newton");
  c.output_newton.every = j.at("newton_every");
  c.output_newton.iterations = j.at("newton_iterations");
  // Models saved before the feature grid existed have none.
  c.grid.cell = j.value("grid_cell", 0.0);
  c.grid.spacings = j.value("grid_spacings", 0.0);
  c.grid.degree = j.value("grid_degree", 2);
  c.grid.newton_iterations = j.value("grid_newton_iterations", 30);
  c.grid.refine_band = j.value("grid_refine_band", 1.0);
  c.grid.surface_share = j.value("grid_surface_share", 0.04);
  // Models saved before the cell quadrature was the default integrated by the particles, with the
  // grid sized from grid_cell or grid_spacings and no extension.
  c.grid.quadrature = j.value("grid_quadrature", std::string("particles")) == "cells"
                          ? DemConfig::GridQuadrature::kCells
                          : DemConfig::GridQuadrature::kParticles;
  c.grid.gauss_points = j.value("grid_gauss_points", 2);
  c.grid.boundary_levels = j.value("grid_boundary_levels", 0);
  c.grid.body_cells = j.value("grid_body_cells", 0.0);
  c.grid.extension_fill = j.value("grid_extension_fill", 0.0);
  c.load_steps = j.value("load_steps", 0);
  c.adam.jitter = j.at("jitter");
  c.adam.jitter_band = j.at("jitter_band");
  c.lbfgs.iterations = j.at("lbfgs_iterations");
  c.lbfgs.history = j.at("lbfgs_history");
  c.lbfgs.max_energy_drop = j.at("polish_max_energy_drop");
  c.lbfgs.max_growth = j.at("polish_max_growth");
  c.lbfgs.tolerance = j.at("tolerance");
  c.max_halvings = j.at("max_halvings");
  c.parametric.enabled = j.at("parametric");
  c.parametric.load_range_min = j.at("load_range_min");
  c.parametric.load_range_max = j.at("load_range_max");
  c.parametric.samples = j.at("parametric_samples");
  c.network.seed = j.at("seed");
  c.network.double_precision = j.at("double_precision");
  // The network's input normalisation (files written before it existed: per axis).
  c.network.thickness_inputs = j.value("thickness_inputs", false);
  // The MLP's loads (files written before they were spread over the surface: on the particles).
  c.surface_loads = j.value("surface_loads", false);
  return c;
}

void putDoubles(std::string& out, const double* data, std::size_t count) {
  out.append(reinterpret_cast<const char*>(data), count * sizeof(double));
}

// Reads doubles sequentially from the payload; running past its end means a damaged header.
class PayloadReader {
 public:
  PayloadReader(const std::string& payload, const std::string& where) : payload_(payload), where_(where) {}
  void get(double* data, std::size_t count) {
    const std::size_t bytes = count * sizeof(double);
    if (offset_ + bytes > payload_.size())
      throw core::Error(where_ + " is corrupt: its header describes more data than the file holds");
    std::memcpy(data, payload_.data() + offset_, bytes);
    offset_ += bytes;
  }
  void expectEnd() const {
    if (offset_ != payload_.size()) throw core::Error(where_ + " is corrupt: unexpected bytes after the network");
  }

 private:
  const std::string& payload_;
  std::string where_;
  std::size_t offset_ = 0;
};

}  // namespace

void saveDemModel(const DemSolver& solver, const std::string& path) {
  const DemState st = solver.state();
  nlohmann::json layers = nlohmann::json::array();
  std::string payload;
  const std::size_t n = st.cloud.size();
  for (std::size_t i = 0; i < n; ++i) putDoubles(payload, st.cloud.positions[i].data(), 3);
  putDoubles(payload, st.cloud.volumes.data(), n);
  for (std::size_t i = 0; i < n; ++i) putDoubles(payload, st.cloud.normals[i].data(), 3);
  putDoubles(payload, st.cloud.areas.data(), n);
  for (std::size_t l = 0; l < st.weights.size(); ++l) {
    layers.push_back({st.weights[l].rows(), st.weights[l].cols()});
    putDoubles(payload, st.weights[l].data(), st.weights[l].size());  // column-major
    putDoubles(payload, st.biases[l].data(), st.biases[l].size());
  }
  putDoubles(payload, st.grid_coefficients.data(), st.grid_coefficients.size());  // column-major
  const nlohmann::json header = {{"config", toJson(st.config)},
                                 {"scenario_yaml", core::toYaml(st.scenario)},
                                 {"particles", n},
                                 {"layers", layers},
                                 {"grid_nodes", st.grid_coefficients.rows()},
                                 {"output_scale", st.output_scale},
                                 {"energy_scale", st.energy_scale},
                                 {"fraction", st.fraction},
                                 {"rescaled", st.rescaled}};
  core::ModelContainer container;
  container.version = kDemModelFileVersion;
  container.header = header.dump();
  container.payload = std::move(payload);
  core::writeModelContainer(path, kMagic, container, kWhat);
}

DemSolver loadDemModel(const std::string& path) {
  const core::ModelContainer container = core::readModelContainer(path, kMagic, kDemModelFileVersion, kWhat);
  const std::string where = std::string(kWhat) + " file '" + path + "'";
  DemState st;
  std::vector<std::pair<long, long>> shapes;
  std::size_t n = 0;
  long grid_nodes = 0;
  try {
    const nlohmann::json header = nlohmann::json::parse(container.header);
    st.config = configFromJson(header.at("config"));
    st.scenario = core::parseScenario(header.at("scenario_yaml").get<std::string>(), where);
    n = header.at("particles");
    for (const auto& shape : header.at("layers")) shapes.emplace_back(shape.at(0), shape.at(1));
    st.output_scale = header.at("output_scale");
    st.energy_scale = header.at("energy_scale");
    st.fraction = header.at("fraction");
    st.rescaled = header.at("rescaled");
    grid_nodes = header.value("grid_nodes", 0L);
  } catch (const nlohmann::json::exception& e) {
    throw core::Error(where + " is corrupt: its header is not what save wrote (" + e.what() + ")");
  }
  if (n == 0 || n > container.payload.size() / (8 * sizeof(double)))
    throw core::Error(where + " is corrupt: it claims " + std::to_string(n) + " particles in " +
                      std::to_string(container.payload.size()) + " bytes");
  PayloadReader reader(container.payload, where);
  st.cloud.resize(n);
  for (std::size_t i = 0; i < n; ++i) reader.get(st.cloud.positions[i].data(), 3);
  reader.get(st.cloud.volumes.data(), n);
  for (std::size_t i = 0; i < n; ++i) reader.get(st.cloud.normals[i].data(), 3);
  reader.get(st.cloud.areas.data(), n);
  for (const auto& [rows, cols] : shapes) {
    if (rows <= 0 || cols <= 0 || rows > 100000 || cols > 100000)
      throw core::Error(where + " is corrupt: a layer of " + std::to_string(rows) + " x " + std::to_string(cols));
    st.weights.emplace_back(rows, cols);
    st.biases.emplace_back(rows);
    reader.get(st.weights.back().data(), st.weights.back().size());
    reader.get(st.biases.back().data(), st.biases.back().size());
  }
  if (grid_nodes < 0 || grid_nodes > 4000000)
    throw core::Error(where + " is corrupt: a feature grid of " + std::to_string(grid_nodes) + " nodes");
  st.grid_coefficients.resize(grid_nodes, grid_nodes > 0 ? 3 : 0);
  reader.get(st.grid_coefficients.data(), st.grid_coefficients.size());
  reader.expectEnd();
  return DemSolver::fromState(st);
}

}  // namespace demnerf::mechanics
