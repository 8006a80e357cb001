#include "demnerf/nerf/ngp_field.hpp"

#include <ATen/Parallel.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>

#include "demnerf/core/error.hpp"
#include "demnerf/nerf/sh_encoding.hpp"

namespace demnerf::nerf {

void MlpGradients::zero() {
  std::fill(density.begin(), density.end(), 0.0f);
  std::fill(color.begin(), color.end(), 0.0f);
}

NgpField::NgpField(const NerfConfig& config, const Box& bounds, double aabb_scale, std::uint64_t seed)
    : config_(config), bounds_(bounds), aabb_scale_(aabb_scale) {
  config.validate();
  for (int a = 0; a < 3; ++a) {
    if (!(bounds.max[a] > bounds.min[a]) || !std::isfinite(bounds.min[a]) || !std::isfinite(bounds.max[a])) {
      throw core::Error("NeRF scene box must have finite min < max on every axis (axis " + std::to_string(a) +
                        ": " + std::to_string(bounds.min[a]) + " .. " + std::to_string(bounds.max[a]) + ")");
    }
  }
  hash_layout_ = HashGridLayout::make(config.hash, aabb_scale);
  const FieldConfig& f = config.field;
  sh_dims_ = f.sh_degree * f.sh_degree;
  density_layout_.dims.push_back(hash_layout_.outputDims());
  for (int l = 0; l < f.density_layers; ++l) density_layout_.dims.push_back(f.density_hidden);
  density_layout_.dims.push_back(f.geometry_features);
  color_layout_.dims.push_back(f.geometry_features + sh_dims_);
  for (int l = 0; l < f.color_layers; ++l) color_layout_.dims.push_back(f.color_hidden);
  color_layout_.dims.push_back(3);

  std::mt19937_64 rng(seed);
  // instant-ngp initialises the table uniformly in +-1e-4: features start near zero so the
  // MLPs first learn a smooth field.
  table_.resize(hash_layout_.parameterCount());
  std::uniform_real_distribution<float> small(-1e-4f, 1e-4f);
  for (float& v : table_) v = small(rng);
  density_layout_.initialize(density_weights_, rng);
  color_layout_.initialize(color_weights_, rng);
  refreshTransposed();
}

void NgpField::refreshTransposed() {
  refreshMlpCopies();
  const bool half = config_.hash.half_table && hash_layout_.features == 2 && halfTableSupported();
  table_half_.resize(half ? table_.size() : 0);
  if (half) toHalf(table_.data(), 0, static_cast<std::int64_t>(table_.size()), table_half_.data());
}

void NgpField::refreshMlpCopies() {
  density_t_.resize(density_weights_.size());
  color_t_.resize(color_weights_.size());
  for (int l = 0; l < density_layout_.layers(); ++l) {
    transpose(density_weights_.data() + density_layout_.offset(l), density_layout_.dims[l],
              density_layout_.dims[l + 1], density_t_.data() + density_layout_.offset(l));
  }
  for (int l = 0; l < color_layout_.layers(); ++l) {
    transpose(color_weights_.data() + color_layout_.offset(l), color_layout_.dims[l], color_layout_.dims[l + 1],
              color_t_.data() + color_layout_.offset(l));
  }
}

void NgpField::toUnit(const float* points, std::int64_t n, float* unit) const {
  float scale[3];
  for (int a = 0; a < 3; ++a) scale[a] = 1.0f / bounds_.size(a);
  for (std::int64_t i = 0; i < n; ++i)
    for (int a = 0; a < 3; ++a) unit[3 * i + a] = (points[3 * i + a] - bounds_.min[a]) * scale[a];
}

void NgpField::forwardChunk(const float* unit, const float* directions, int n, FieldWorkspace& ws, float* sigma,
                            float* rgb) const {
  const int enc_dims = hash_layout_.outputDims();
  const int dl = density_layout_.layers();
  ws.encoding.resize(static_cast<std::size_t>(kChunk) * enc_dims);
  ws.density_act.resize(dl);
  const auto encode_start = std::chrono::steady_clock::now();
  if (table_half_.empty()) hashEncodeForward(hash_layout_, table_.data(), unit, n, ws.encoding.data());
  else hashEncodeForwardHalf(hash_layout_, table_half_.data(), unit, n, ws.encoding.data());
  ws.encode_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - encode_start).count();
  const float* input = ws.encoding.data();
  for (int l = 0; l < dl; ++l) {
    const int out = density_layout_.dims[l + 1];
    ws.density_act[l].resize(static_cast<std::size_t>(kChunk) * out);
    matmulRows(input, n, density_layout_.dims[l], density_weights_.data() + density_layout_.offset(l), out,
               ws.density_act[l].data(), l + 1 < dl);
    input = ws.density_act[l].data();
  }
  const int geo = density_layout_.dims.back();
  for (int i = 0; i < n; ++i) {
    // Points outside the box (clamped onto it by the encoding) are empty space.
    const float* u = unit + 3 * i;
    const bool inside = u[0] >= 0.0f && u[0] <= 1.0f && u[1] >= 0.0f && u[1] <= 1.0f && u[2] >= 0.0f && u[2] <= 1.0f;
    sigma[i] = inside ? truncExp(input[i * geo]) : 0.0f;
  }
  if (!rgb) return;

  const int cin = color_layout_.dims[0];
  ws.color_input.resize(static_cast<std::size_t>(kChunk) * cin);
  for (int i = 0; i < n; ++i) {
    float* c = ws.color_input.data() + i * cin;
    std::copy(input + i * geo, input + (i + 1) * geo, c);
    const float* d = directions + 3 * i;
    shEncode(config_.field.sh_degree, d[0], d[1], d[2], c + geo);
  }
  const int cl = color_layout_.layers();
  ws.color_act.resize(cl);
  input = ws.color_input.data();
  for (int l = 0; l < cl; ++l) {
    const int out = color_layout_.dims[l + 1];
    ws.color_act[l].resize(static_cast<std::size_t>(kChunk) * out);
    matmulRows(input, n, color_layout_.dims[l], color_weights_.data() + color_layout_.offset(l), out,
               ws.color_act[l].data(), l + 1 < cl);
    input = ws.color_act[l].data();
  }
  for (int i = 0; i < 3 * n; ++i) rgb[i] = 1.0f / (1.0f + __builtin_expf(-input[i]));
}

void NgpField::backwardChunk(int n, FieldWorkspace& ws, const float* grad_sigma, const float* grad_rgb,
                             MlpGradients& grads, float* grad_encoding) const {
  const int cl = color_layout_.layers();
  const int dl = density_layout_.layers();
  std::size_t widest = 0;
  for (int d : color_layout_.dims) widest = std::max<std::size_t>(widest, d);
  for (int d : density_layout_.dims) widest = std::max<std::size_t>(widest, d);
  ws.grad_a.resize(static_cast<std::size_t>(kChunk) * widest);
  ws.grad_b.resize(static_cast<std::size_t>(kChunk) * widest);
  float* g = ws.grad_a.data();
  float* g_next = ws.grad_b.data();

  // Sigmoid of the colour logits.
  const float* out = ws.color_act[cl - 1].data();
  for (int i = 0; i < 3 * n; ++i) {
    const float s = 1.0f / (1.0f + __builtin_expf(-out[i]));
    g[i] = grad_rgb[i] * s * (1.0f - s);
  }
  for (int l = cl - 1; l >= 0; --l) {
    const int in_dims = color_layout_.dims[l], out_dims = color_layout_.dims[l + 1];
    const float* act_in = l == 0 ? ws.color_input.data() : ws.color_act[l - 1].data();
    accumulateWeightGrad(act_in, n, in_dims, g, out_dims, grads.color.data() + color_layout_.offset(l));
    matmulRows(g, n, out_dims, color_t_.data() + color_layout_.offset(l), in_dims, g_next, false);
    if (l > 0) {
      // ReLU: the stored output is zero exactly where the unit was inactive.
      for (std::int64_t i = 0; i < static_cast<std::int64_t>(n) * in_dims; ++i)
        if (act_in[i] <= 0.0f) g_next[i] = 0.0f;
    }
    std::swap(g, g_next);
  }
  // g now holds d/d(color_input); its first `geo` columns flow into the density output.
  const int geo = density_layout_.dims.back();
  const int cin = color_layout_.dims[0];
  const float* dens_out = ws.density_act[dl - 1].data();
  for (int i = 0; i < n; ++i) {
    float* dst = g_next + i * geo;
    const float* src = g + i * cin;
    for (int j = 0; j < geo; ++j) dst[j] = src[j];
    const float x = dens_out[i * geo];
    const float clamped = std::min(std::max(x, -15.0f), 15.0f);
    dst[0] += grad_sigma[i] * __builtin_expf(clamped);
  }
  std::swap(g, g_next);
  for (int l = dl - 1; l >= 0; --l) {
    const int in_dims = density_layout_.dims[l], out_dims = density_layout_.dims[l + 1];
    const float* act_in = l == 0 ? ws.encoding.data() : ws.density_act[l - 1].data();
    accumulateWeightGrad(act_in, n, in_dims, g, out_dims, grads.density.data() + density_layout_.offset(l));
    float* dst = l == 0 ? grad_encoding : g_next;
    matmulRows(g, n, out_dims, density_t_.data() + density_layout_.offset(l), in_dims, dst, false);
    if (l > 0) {
      for (std::int64_t i = 0; i < static_cast<std::int64_t>(n) * in_dims; ++i)
        if (act_in[i] <= 0.0f) g_next[i] = 0.0f;
      std::swap(g, g_next);
    }
  }
}

void NgpField::density(const float* points, std::int64_t n, float* sigma) const {
  at::parallel_for(0, (n + kChunk - 1) / kChunk, 1, [&](std::int64_t begin, std::int64_t end) {
    thread_local FieldWorkspace ws;
    for (std::int64_t c = begin; c < end; ++c) {
      const std::int64_t first = c * kChunk;
      const int count = static_cast<int>(std::min<std::int64_t>(kChunk, n - first));
      ws.unit.resize(3 * kChunk);
      toUnit(points + 3 * first, count, ws.unit.data());
      forwardChunk(ws.unit.data(), nullptr, count, ws, sigma + first, nullptr);
    }
  });
}

void NgpField::query(const float* points, const float* directions, std::int64_t n, float* sigma,
                     float* rgb) const {
  at::parallel_for(0, (n + kChunk - 1) / kChunk, 1, [&](std::int64_t begin, std::int64_t end) {
    thread_local FieldWorkspace ws;
    for (std::int64_t c = begin; c < end; ++c) {
      const std::int64_t first = c * kChunk;
      const int count = static_cast<int>(std::min<std::int64_t>(kChunk, n - first));
      ws.unit.resize(3 * kChunk);
      toUnit(points + 3 * first, count, ws.unit.data());
      forwardChunk(ws.unit.data(), directions + 3 * first, count, ws, sigma + first, rgb + 3 * first);
    }
  });
}

}  // namespace demnerf::nerf
