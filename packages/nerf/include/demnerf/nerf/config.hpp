#pragma once
// Every tunable of the NeRF (encoding, networks, occupancy grid, marching, training), with
// defaults chosen for a 2-core CPU, and their YAML / JSON forms.

#include <cstdint>
#include <nlohmann/json_fwd.hpp>
#include <string>

namespace demnerf::nerf {

/// Multiresolution hash encoding (instant-ngp): `levels` grids from base to finest resolution.
struct HashGridConfig {
  int levels = 16;
  int features_per_level = 2;
  int log2_table_size = 15;       ///< entries per level (coarse levels that fit are dense); 15 keeps the tables in cache
  int base_resolution = 16;
  int finest_resolution = 0;      ///< 0: 512 x the dataset's aabb_scale
  /// The forward (training, occupancy, rendering) reads a half-precision copy of the table
  /// (2 features per level and an AVX-512 + F16C build; else the float table); Adam keeps
  /// the float master. Half the bytes for the fine levels' cache-missing gathers.
  bool half_table = true;
};

/// Density MLP (hash features -> log-density + geometry features) and colour MLP
/// (geometry features + SH(direction) -> RGB). Hidden layers use ReLU; no biases.
struct FieldConfig {
  int density_hidden = 32;    ///< instant-ngp uses 64; 32 trains ~2x faster on a CPU at a small cost
  int density_layers = 1;     ///< hidden layers of the density MLP
  int geometry_features = 16; ///< density MLP outputs (the first is log-density)
  int color_hidden = 32;
  int color_layers = 2;       ///< hidden layers of the colour MLP
  int sh_degree = 4;          ///< spherical harmonics degree of the direction encoding (1..4)
};

/// Occupancy grid over the scene box: EMA of optical thickness, bitfield, instant-ngp schedule.
struct OccupancyConfig {
  int resolution = 64;          ///< cells per axis (of each cascade)
  /// Nested grids, each twice the extent of the one inside (instant-ngp's cascades for
  /// unbounded scenes); 0: 1 + log2(aabb_scale), i.e. 3 for the fox. Default 1: on the fox
  /// cascades cost 1.4 dB at 600 iterations and saved no samples (docs/nerf_real_captures.md).
  int cascades = 1;
  /// Keeps empty the cells no training camera sees (the field is unconstrained there). Off by
  /// default: on the fox it saved no samples and cost 0.4 dB at 600 iterations.
  bool cull_unseen = false;
  int update_interval = 16;     ///< training steps between updates
  int warmup_steps = 256;       ///< until then every cell is re-sampled at each update
  double decay = 0.95;          ///< EMA decay of the stored thickness
  double threshold = 0.01;      ///< occupied when thickness > min(threshold, mean)
};

/// Ray marching through the scene box.
struct MarchConfig {
  int steps_per_diagonal = 512;     ///< smallest step = box diagonal / this
  double cone_angle = -1.0;         ///< step grows as t * cone_angle; < 0: 0 if aabb_scale <= 1 else 1/256
  double max_step_cells = 1.0;      ///< largest step, in occupancy cells
  int max_samples = 1024;           ///< per ray
  double near = 0.05;               ///< metres in front of the camera where rays start
  double min_transmittance = 1e-4;  ///< rays stop once less light than this gets through
  int samples_per_round = 8;        ///< samples taken per ray before the network is asked
  /// Rendering (not training) may march coarser: steps grow as t * render_cone_angle and rays
  /// stop below render_min_transmittance. < 0: auto, i.e. for unbounded scenes (aabb_scale > 1)
  /// 1/128 and 0.01 (on the fox: 1.8x fewer samples for -0.06 dB), else the training values.
  double render_cone_angle = -1.0;
  double render_min_transmittance = -1.0;
};

struct TrainConfig {
  double learning_rate = 1e-2;
  double final_learning_rate_ratio = 0.1;  ///< lr decays exponentially to lr * this at the end
  double decay_start = 0.5;                ///< fraction of the budget after which lr decays
  double beta1 = 0.9, beta2 = 0.99, epsilon = 1e-15;
  double weight_decay = 1e-6;              ///< on MLP weights only (as instant-ngp)
  /// Samples per batch; the ray count adapts to reach it. 2^14 trains faster at equal time on
  /// the fox and the T-bar (docs/nerf_real_captures.md, "Training speed") but not on the
  /// nerf_node rostest's small cuboid; set it per scene (nerf_fox.yaml).
  int target_samples = 1 << 16;
  int min_rays = 512, max_rays = 1 << 14;
  /// Samples behind which less than this much light is left get no gradient (their colour
  /// still counts in the forward): their gradient is bounded by that fraction of the ray's, and
  /// on the fox most marched samples lie there. 0: every sample that the ray reached.
  double gradient_min_transmittance = 0.0;
  /// Weight of a prior that space is empty where the images cannot tell: density_prior * sum of
  /// sigma * min_step over density_prior_per_ray random points behind each training ray's stop
  /// (once its light is below march.min_transmittance), per ray of the batch. Past its stop a
  /// ray gives no gradient, so without it the density behind the visible surfaces is never fit;
  /// on the fox with rays stopping at 1 % it fills the object's box for an extraction.
  /// 0: off (docs/nerf_real_captures.md, "seventh step").
  double density_prior = 0.0;
  int density_prior_per_ray = 2;  ///< 1..4 (a block's prior points fill at most one chunk)
  /// Weight of mip-NeRF 360's distortion loss (distortion.hpp): distortion * the mean over the
  /// batch's rays of sum_ij w_i w_j |s_i - s_j| + 1/3 sum_i w_i^2 ds_i, distances in box
  /// diagonals. It concentrates each ray's weight in a short stretch, for a sharper density
  /// edge than the colour alone gives (docs/mechanics_matrix_nerf.md, "A sharper density edge":
  /// 0.01-0.03 gave a slightly truer T-bar; the fox gained at 0.003-0.01 and failed at 0.03).
  /// 0: off.
  double distortion = 0.0;
  std::string loss = "l2";                 ///< l2 | huber
  double huber_delta = 0.1;
  bool random_background = true;           ///< for RGBA data (instant-ngp): new colour per ray
  std::uint64_t seed = 1;
  int threads = 0;                         ///< 0: all cores; the entry point applies it (configureRuntime), not the Trainer
};

struct NerfConfig {
  HashGridConfig hash;
  FieldConfig field;
  OccupancyConfig occupancy;
  MarchConfig march;
  TrainConfig train;
  /// Background behind the object for rendering and evaluation of RGBA data.
  double background[3] = {1.0, 1.0, 1.0};

  /// Throws core::Error naming the first value out of range.
  void validate() const;
};

/// Reads a nerf.yaml (every key optional; unknown keys are errors naming the key).
NerfConfig loadNerfConfig(const std::string& path);
/// The same from YAML text over `base` (keys left out keep base's value); `source` names the text
/// in messages. nerf_node reads its ~nerf namespace so, over ~nerf_config's file.
NerfConfig parseNerfConfig(const std::string& yaml_text, const std::string& source = "nerf config",
                           NerfConfig base = {});

nlohmann::json toJson(const NerfConfig& config);
NerfConfig nerfConfigFromJson(const nlohmann::json& json);

}  // namespace demnerf::nerf
