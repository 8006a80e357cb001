#include "demnerf/nerf/config.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <sstream>
#include <utility>
#include <variant>
#include <vector>

#include "demnerf/core/error.hpp"

namespace demnerf::nerf {
namespace {

using core::Error;
using Value = std::variant<int*, double*, std::uint64_t*, std::string*, bool*>;

struct Entry {
  const char* section;
  const char* key;
  Value value;
};

// One list of (section, key, field) drives YAML reading, JSON writing and JSON reading, so
// the three cannot disagree.
std::vector<Entry> entries(NerfConfig& c) {
  return {
      {"hash", "levels", &c.hash.levels},
      {"hash", "features_per_level", &c.hash.features_per_level},
      {"hash", "log2_table_size", &c.hash.log2_table_size},
      {"hash", "base_resolution", &c.hash.base_resolution},
      {"hash", "finest_resolution", &c.hash.finest_resolution},
      {"hash", "half_table", &c.hash.half_table},
      {"field", "density_hidden", &c.field.density_hidden},
      {"field", "density_layers", &c.field.density_layers},
      {"field", "geometry_features", &c.field.geometry_features},
      {"field", "color_hidden", &c.field.color_hidden},
      {"field", "color_layers", &c.field.color_layers},
      {"field", "sh_degree", &c.field.sh_degree},
      {"occupancy", "resolution", &c.occupancy.resolution},
      {"occupancy", "cascades", &c.occupancy.cascades},
      {"occupancy", "cull_unseen", &c.occupancy.cull_unseen},
      {"occupancy", "update_interval", &c.occupancy.update_interval},
      {"occupancy", "warmup_steps", &c.occupancy.warmup_steps},
      {"occupancy", "decay", &c.occupancy.decay},
      {"occupancy", "threshold", &c.occupancy.threshold},
      {"march", "steps_per_diagonal", &c.march.steps_per_diagonal},
      {"march", "cone_angle", &c.march.cone_angle},
      {"march", "max_step_cells", &c.march.max_step_cells},
      {"march", "max_samples", &c.march.max_samples},
      {"march", "near", &c.march.near},
      {"march", "min_transmittance", &c.march.min_transmittance},
      {"march", "samples_per_round", &c.march.samples_per_round},
      {"march", "render_cone_angle", &c.march.render_cone_angle},
      {"march", "render_min_transmittance", &c.march.render_min_transmittance},
      {"train", "learning_rate", &c.train.learning_rate},
      {"train", "final_learning_rate_ratio", &c.train.final_learning_rate_ratio},
      {"train", "decay_start", &c.train.decay_start},
      {"train", "beta1", &c.train.beta1},
      {"train", "beta2", &c.train.beta2},
      {"train", "epsilon", &c.train.epsilon},
      {"train", "weight_decay", &c.train.weight_decay},
      {"train", "target_samples", &c.train.target_samples},
      {"train", "min_rays", &c.train.min_rays},
      {"train", "max_rays", &c.train.max_rays},
      {"train", "gradient_min_transmittance", &c.train.gradient_min_transmittance},
      {"train", "density_prior", &c.train.density_prior},
      {"train", "density_prior_per_ray", &c.train.density_prior_per_ray},
      {"train", "distortion", &c.train.distortion},
      {"train", "loss", &c.train.loss},
      {"train", "huber_delta", &c.train.huber_delta},
      {"train", "random_background", &c.train.random_background},
      {"train", "seed", &c.train.seed},
      {"train", "threads", &c.train.threads},
  };
}

void check(bool ok, const std::string& what) {
  if (!ok) throw Error("nerf config: " + what);
}

}  // namespace

void NerfConfig::validate() const {
  check(hash.levels >= 1 && hash.levels <= 32, "hash.levels must be in [1, 32], got " + std::to_string(hash.levels));
  check(hash.features_per_level >= 1 && hash.features_per_level <= 8,
        "hash.features_per_level must be in [1, 8], got " + std::to_string(hash.features_per_level));
  check(hash.log2_table_size >= 8 && hash.log2_table_size <= 24,
        "hash.log2_table_size must be in [8, 24], got " + std::to_string(hash.log2_table_size));
  check(hash.base_resolution >= 2, "hash.base_resolution must be >= 2, got " + std::to_string(hash.base_resolution));
  check(hash.finest_resolution == 0 || hash.finest_resolution >= hash.base_resolution,
        "hash.finest_resolution must be 0 (auto) or >= base_resolution, got " + std::to_string(hash.finest_resolution));
  check(field.density_hidden >= 1 && field.density_hidden <= 256, "field.density_hidden must be in [1, 256]");
  check(field.color_hidden >= 1 && field.color_hidden <= 256, "field.color_hidden must be in [1, 256]");
  check(field.density_layers >= 1 && field.density_layers <= 8, "field.density_layers must be in [1, 8]");
  check(field.color_layers >= 1 && field.color_layers <= 8, "field.color_layers must be in [1, 8]");
  check(field.geometry_features >= 1 && field.geometry_features <= 64, "field.geometry_features must be in [1, 64]");
  check(field.sh_degree >= 1 && field.sh_degree <= 4, "field.sh_degree must be in [1, 4], got " + std::to_string(field.sh_degree));
  check(occupancy.resolution >= 8 && occupancy.resolution <= 512 && occupancy.resolution % 8 == 0,
        "occupancy.resolution must be a multiple of 8 in [8, 512], got " + std::to_string(occupancy.resolution));
  check(occupancy.cascades >= 0 && occupancy.cascades <= 8,
        "occupancy.cascades must be in [0, 8] (0: from aabb_scale), got " + std::to_string(occupancy.cascades));
  check(occupancy.update_interval >= 1, "occupancy.update_interval must be >= 1");
  check(occupancy.decay > 0 && occupancy.decay <= 1, "occupancy.decay must be in (0, 1]");
  check(occupancy.threshold >= 0, "occupancy.threshold must be >= 0");
  check(march.steps_per_diagonal >= 8, "march.steps_per_diagonal must be >= 8");
  check(march.max_samples >= 1, "march.max_samples must be >= 1");
  check(march.samples_per_round >= 1, "march.samples_per_round must be >= 1");
  check(march.near >= 0, "march.near must be >= 0");
  check(march.max_step_cells > 0, "march.max_step_cells must be > 0");
  check(march.min_transmittance >= 0 && march.min_transmittance < 1, "march.min_transmittance must be in [0, 1)");
  check(march.render_min_transmittance < 1, "march.render_min_transmittance must be < 1 (< 0: auto)");
  check(train.learning_rate > 0 && std::isfinite(train.learning_rate), "train.learning_rate must be > 0");
  check(train.final_learning_rate_ratio > 0 && train.final_learning_rate_ratio <= 1,
        "train.final_learning_rate_ratio must be in (0, 1]");
  check(train.decay_start >= 0 && train.decay_start <= 1, "train.decay_start must be in [0, 1]");
  check(train.beta1 >= 0 && train.beta1 < 1 && train.beta2 >= 0 && train.beta2 < 1, "train.beta1/beta2 must be in [0, 1)");
  check(train.epsilon > 0, "train.epsilon must be > 0");
  check(train.target_samples >= 64, "train.target_samples must be >= 64");
  check(train.min_rays >= 1 && train.max_rays >= train.min_rays, "train.min_rays must be >= 1 and <= train.max_rays");
  check(train.gradient_min_transmittance >= 0 && train.gradient_min_transmittance < 1,
        "train.gradient_min_transmittance must be in [0, 1)");
  check(train.density_prior >= 0 && std::isfinite(train.density_prior), "train.density_prior must be >= 0");
  check(train.density_prior_per_ray >= 1 && train.density_prior_per_ray <= 4,
        "train.density_prior_per_ray must be in [1, 4], got " + std::to_string(train.density_prior_per_ray));
  check(train.distortion >= 0 && std::isfinite(train.distortion), "train.distortion must be >= 0");
  check(train.loss == "l2" || train.loss == "huber", "train.loss must be 'l2' or 'huber', got '" + train.loss + "'");
  check(train.threads >= 0, "train.threads must be >= 0");
  for (double b : background) check(b >= 0 && b <= 1, "background components must be in [0, 1]");
}

NerfConfig parseNerfConfig(const std::string& yaml_text, const std::string& source, NerfConfig base) {
  NerfConfig config = std::move(base);
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw Error(source + ": not valid YAML: " + e.what());
  }
  if (!root || root.IsNull()) return config;
  if (!root.IsMap()) throw Error(source + ": expected a mapping of sections (hash, field, occupancy, march, train)");
  auto list = entries(config);
  for (const auto& section : root) {
    const std::string name = section.first.as<std::string>();
    if (name == "background") {
      if (!section.second.IsSequence() || section.second.size() != 3) throw Error(source + ": 'background' must be [r, g, b]");
      for (int i = 0; i < 3; ++i) config.background[i] = section.second[i].as<double>();
      continue;
    }
    bool known_section = false;
    for (const Entry& e : list) known_section |= name == e.section;
    if (!known_section) throw Error(source + ": unknown section '" + name + "' (known: hash, field, occupancy, march, train, background)");
    if (!section.second.IsMap()) throw Error(source + ": section '" + name + "' must be a mapping");
    for (const auto& item : section.second) {
      const std::string key = item.first.as<std::string>();
      const Entry* found = nullptr;
      for (const Entry& e : list) if (name == e.section && key == e.key) found = &e;
      if (!found) throw Error(source + ": unknown key '" + name + "." + key + "'");
      try {
        std::visit([&](auto* field) { *field = item.second.as<std::remove_pointer_t<decltype(field)>>(); }, found->value);
      } catch (const YAML::Exception&) {
        throw Error(source + ": '" + name + "." + key + "' has a value of the wrong type: '" + YAML::Dump(item.second) + "'");
      }
    }
  }
  config.validate();
  return config;
}

NerfConfig loadNerfConfig(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error("cannot read nerf config '" + path + "'");
  std::stringstream text;
  text << in.rdbuf();
  return parseNerfConfig(text.str(), path);
}

nlohmann::json toJson(const NerfConfig& config) {
  NerfConfig copy = config;
  nlohmann::json json;
  for (const Entry& e : entries(copy)) {
    std::visit([&](auto* field) { json[e.section][e.key] = *field; }, e.value);
  }
  json["background"] = {config.background[0], config.background[1], config.background[2]};
  return json;
}

NerfConfig nerfConfigFromJson(const nlohmann::json& json) {
  NerfConfig config;
  try {
    for (const Entry& e : entries(config)) {
      if (!json.contains(e.section) || !json[e.section].contains(e.key)) continue;  // older files: default
      std::visit([&](auto* field) { json[e.section][e.key].get_to(*field); }, e.value);
    }
    // Model files written before cascades existed hold a single grid.
    if (!json.contains("occupancy") || !json["occupancy"].contains("cascades")) config.occupancy.cascades = 1;
    if (json.contains("background")) {
      for (int i = 0; i < 3; ++i) config.background[i] = json["background"].at(i).get<double>();
    }
  } catch (const nlohmann::json::exception& ex) {
    throw Error(std::string("model config: ") + ex.what());
  }
  config.validate();
  return config;
}

}  // namespace demnerf::nerf
