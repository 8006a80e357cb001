#pragma once
// The instant-NGP field: hash encoding -> density MLP -> (geometry features, SH(direction))
// -> colour MLP, with chunk kernels for training (forward that keeps activations, backward).

#include <cstdint>
#include <vector>

#include "demnerf/nerf/config.hpp"
#include "demnerf/nerf/field.hpp"
#include "demnerf/nerf/hash_encoding.hpp"
#include "demnerf/nerf/mlp.hpp"

namespace demnerf::nerf {

/// Activations of one chunk of points, kept between forward and backward.
struct FieldWorkspace {
  std::vector<float> unit, encoding, color_input, rgb_logits, sigma_logit;
  std::vector<std::vector<float>> density_act, color_act;  ///< per layer outputs
  std::vector<float> grad_a, grad_b;                       ///< backward scratch
  double encode_seconds = 0;  ///< time in the hash encoding forward (for profiles)
};

/// Weight gradients of the two MLPs (one set per thread during training).
struct MlpGradients {
  std::vector<float> density, color;
  void zero();
};

class NgpField : public Field {
 public:
  /// Largest number of points a chunk kernel handles at once (activations stay in L2).
  static constexpr int kChunk = 256;

  NgpField(const NerfConfig& config, const Box& bounds, double aabb_scale, std::uint64_t seed);

  Box bounds() const override { return bounds_; }
  void density(const float* points, std::int64_t n, float* sigma) const override;
  void query(const float* points, const float* directions, std::int64_t n, float* sigma,
             float* rgb) const override;

  const HashGridLayout& hashLayout() const { return hash_layout_; }
  const MlpLayout& densityLayout() const { return density_layout_; }
  const MlpLayout& colorLayout() const { return color_layout_; }
  const NerfConfig& config() const { return config_; }
  double aabbScale() const { return aabb_scale_; }

  std::vector<float>& table() { return table_; }
  const std::vector<float>& table() const { return table_; }
  std::vector<float>& densityWeights() { return density_weights_; }
  const std::vector<float>& densityWeights() const { return density_weights_; }
  std::vector<float>& colorWeights() { return color_weights_; }
  const std::vector<float>& colorWeights() const { return color_weights_; }

  /// World points -> unit cube of the hash grid; returns false (and writes nothing useful)
  /// for points outside the box.
  void toUnit(const float* points, std::int64_t n, float* unit) const;

  /// Chunk forward on unit-cube points (n <= kChunk). rgb null: density only.
  void forwardChunk(const float* unit, const float* directions, int n, FieldWorkspace& ws, float* sigma,
                    float* rgb) const;
  /// Chunk backward after forwardChunk with rgb: accumulates weight gradients and writes
  /// d(loss)/d(encoding) [n x levels*features] for the hash table update.
  void backwardChunk(int n, FieldWorkspace& ws, const float* grad_sigma, const float* grad_rgb,
                     MlpGradients& grads, float* grad_encoding) const;
  /// Refreshes every derived copy of the weights (the transposed MLP weights backwardChunk
  /// uses, the half-precision table the forward reads); call after changing the weights.
  void refreshTransposed();
  /// Only the MLPs' transposed copies (the trainer keeps the half table current entry by entry).
  void refreshMlpCopies();
  /// The half-precision copy of the table the forward reads (2 halves per entry), or null when
  /// the forward reads the float table (hash.half_table off, features != 2, or no support).
  std::uint16_t* halfTable() { return table_half_.empty() ? nullptr : table_half_.data(); }

 private:
  NerfConfig config_;
  Box bounds_;
  double aabb_scale_;
  HashGridLayout hash_layout_;
  MlpLayout density_layout_, color_layout_;
  int sh_dims_;
  std::vector<float> table_, density_weights_, color_weights_;
  std::vector<float> density_t_, color_t_;  ///< transposed copies for the input gradients
  std::vector<std::uint16_t> table_half_;   ///< the forward's copy of table_ (see halfTable())
};

/// trunc_exp: exp with the input clamped, so densities neither overflow nor get huge steps.
inline float truncExp(float x) { return __builtin_expf(x < 15.0f ? x : 15.0f); }

}  // namespace demnerf::nerf
