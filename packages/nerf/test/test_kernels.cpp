// Gradient checks of the hand-written kernels against finite differences.

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "demnerf/nerf/compositing.hpp"
#include "demnerf/nerf/mlp.hpp"
#include "demnerf/nerf/ngp_field.hpp"
#include "demnerf/nerf/sh_encoding.hpp"
#include "demnerf/nerf/torch_ops.hpp"

namespace demnerf::nerf {
namespace {

HashGridConfig smallGrid() {
  HashGridConfig c;
  c.levels = 4;
  c.features_per_level = 2;
  c.log2_table_size = 9;  // levels above 7^3 entries are hashed: both index paths are exercised
  c.base_resolution = 4;
  c.finest_resolution = 40;
  return c;
}

// Points whose coordinates sit at least `margin` (in cells) from every level's cell faces, so
// the piecewise-trilinear encoding is smooth within the finite-difference step.
torch::Tensor interiorPoints(const HashGridLayout& layout, int n, float margin, std::mt19937& rng) {
  std::uniform_real_distribution<float> u(0.02f, 0.98f);
  auto p = torch::empty({n, 3});
  int filled = 0;
  while (filled < n) {
    float x[3] = {u(rng), u(rng), u(rng)};
    bool ok = true;
    for (int l = 0; l < layout.levels && ok; ++l)
      for (float v : x) {
        const float s = v * layout.resolution[l];
        const float f = s - std::floor(s);
        ok &= f > margin && f < 1 - margin;
      }
    if (!ok) continue;
    for (int a = 0; a < 3; ++a) p[filled][a] = x[a];
    ++filled;
  }
  return p;
}

TEST(HashEncoding, LayoutUsesDenseCoarseAndHashedFineLevels) {
  const HashGridLayout layout = HashGridLayout::make(smallGrid());
  ASSERT_EQ(layout.levels, 4);
  EXPECT_EQ(layout.resolution.front(), 4);
  EXPECT_EQ(layout.resolution.back(), 40);
  EXPECT_TRUE(layout.dense.front());
  EXPECT_FALSE(layout.dense.back());
  EXPECT_EQ(layout.entries.front(), 125);
  EXPECT_EQ(layout.entries.back(), 512);
}

TEST(HashEncoding, InterpolatesExactlyAtGridVertices) {
  const HashGridLayout layout = HashGridLayout::make(smallGrid());
  std::vector<float> table(layout.parameterCount());
  for (std::size_t i = 0; i < table.size(); ++i) table[i] = static_cast<float>(i % 97) * 0.01f;
  // The vertex (1, 2, 3) of level 0 (resolution 4, dense): entry (3 * 5 + 2) * 5 + 1.
  const float p[3] = {1.0f / 4, 2.0f / 4, 3.0f / 4};
  std::vector<float> out(layout.outputDims());
  hashEncodeForward(layout, table.data(), p, 1, out.data());
  const int entry = (3 * 5 + 2) * 5 + 1;
  EXPECT_NEAR(out[0], table[2 * entry], 1e-6);
  EXPECT_NEAR(out[1], table[2 * entry + 1], 1e-6);
}

TEST(HashEncoding, TableGradientMatchesFiniteDifferences) {
  const HashGridLayout layout = HashGridLayout::make(smallGrid());
  std::mt19937 rng(3);
  auto positions = interiorPoints(layout, 64, 0.0f, rng);
  auto table = (torch::rand({layout.parameterCount()}) - 0.5).requires_grad_(true);
  auto weights = torch::randn({64, layout.outputDims()});
  auto loss = (hashEncode(positions, table, layout) * weights).sum();
  loss.backward();
  auto grad = table.grad();
  // The encoding is linear in the table, so a large step is exact up to rounding.
  torch::NoGradGuard guard;
  std::uniform_int_distribution<std::int64_t> pick(0, layout.parameterCount() - 1);
  int nonzero = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const std::int64_t i = pick(rng);
    auto plus = table.clone();
    auto minus = table.clone();
    plus[i] += 0.5;
    minus[i] -= 0.5;
    const double fd = ((hashEncode(positions, plus, layout) * weights).sum() -
                       (hashEncode(positions, minus, layout) * weights).sum()).item<double>();
    EXPECT_NEAR(grad[i].item<double>(), fd, 1e-3 * (1 + std::fabs(fd))) << "entry " << i;
    nonzero += std::fabs(fd) > 1e-6;
  }
  EXPECT_GT(nonzero, 20);  // the check touched entries that matter
}

// The training step scatters a level-major copy of the encoding gradient (one level's
// samples contiguous); it must add exactly what the row-major kernel, checked against finite
// differences above, adds, over more points than one run of the kernel (256) holds.
TEST(HashEncoding, LevelMajorScatterEqualsRowMajor) {
  const HashGridLayout layout = HashGridLayout::make(smallGrid());
  const int n = 300, F = layout.features, dims = layout.outputDims();
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-0.05f, 1.05f), g(-1.0f, 1.0f);  // some clamped
  std::vector<float> pos(3 * n), grad(n * dims), level_major(n * dims);
  for (float& v : pos) v = u(rng);
  for (float& v : grad) v = g(rng);
  for (int l = 0; l < layout.levels; ++l)
    for (int i = 0; i < n; ++i)
      for (int f = 0; f < F; ++f) level_major[(l * n + i) * F + f] = grad[i * dims + l * F + f];
  std::vector<float> want(layout.parameterCount(), 0.0f), got(want.size(), 0.0f);
  std::vector<std::uint8_t> want_touched(layout.total_entries, 0), got_touched(want_touched);
  hashEncodeBackwardTable(layout, pos.data(), n, grad.data(), want.data(), 0, layout.levels, want_touched.data());
  for (int l = layout.levels - 1; l >= 0; --l)  // any level order: levels own disjoint ranges
    hashEncodeBackwardLevel(layout, pos.data(), n, level_major.data() + l * n * F, F, got.data(), l, got_touched.data());
  EXPECT_EQ(got, want);
  EXPECT_EQ(got_touched, want_touched);
  int nonzero = 0;
  for (float v : got) nonzero += v != 0.0f;
  EXPECT_GT(nonzero, 200);
}

TEST(HashEncoding, PositionGradientMatchesFiniteDifferences) {
  const HashGridLayout layout = HashGridLayout::make(smallGrid());
  std::mt19937 rng(5);
  auto positions = interiorPoints(layout, 32, 0.05f, rng).requires_grad_(true);
  auto table = torch::rand({layout.parameterCount()}) - 0.5;
  auto weights = torch::randn({32, layout.outputDims()});
  (hashEncode(positions, table, layout) * weights).sum().backward();
  auto grad = positions.grad();
  torch::NoGradGuard guard;
  const float eps = 1e-3f;  // < 0.05 cells of the finest level (40): stays inside the cell
  for (int i = 0; i < 32; ++i) {
    for (int a = 0; a < 3; ++a) {
      auto plus = positions.detach().clone();
      auto minus = positions.detach().clone();
      plus[i][a] += eps;
      minus[i][a] -= eps;
      const double fd = ((hashEncode(plus, table, layout) * weights).sum() -
                         (hashEncode(minus, table, layout) * weights).sum()).item<double>() / (2 * eps);
      EXPECT_NEAR(grad[i][a].item<double>(), fd, 2e-2 * (1 + std::fabs(fd))) << "point " << i << " axis " << a;
    }
  }
}

TEST(Compositing, BackwardMatchesFiniteDifferences) {
  torch::manual_seed(7);
  const int rays = 4, per_ray = 6, s = rays * per_ray;
  auto sigma = (torch::rand({s}) * 20).requires_grad_(true);
  auto rgb = torch::rand({s, 3}).requires_grad_(true);
  auto dt = torch::full({s}, 0.05f);
  auto t = torch::arange(s).to(torch::kFloat32).remainder(per_ray) * 0.05f + 1.0f;
  auto offsets = torch::arange(0, s + 1, per_ray).to(torch::kInt64);
  auto bg = torch::rand({rays, 3});
  auto wc = torch::randn({rays, 3}), wo = torch::randn({rays}), wd = torch::randn({rays});
  auto objective = [&](const torch::Tensor& sg, const torch::Tensor& c) {
    auto r = volumeRender(sg, c, dt, t, offsets, bg);
    return (r.color * wc).sum() + (r.opacity * wo).sum() + (r.depth * wd).sum();
  };
  objective(sigma, rgb).backward();
  torch::NoGradGuard guard;
  const double eps = 1e-2;
  for (int i = 0; i < s; ++i) {
    auto p = sigma.detach().clone(), m = sigma.detach().clone();
    p[i] += eps;
    m[i] -= eps;
    const double fd = (objective(p, rgb.detach()) - objective(m, rgb.detach())).item<double>() / (2 * eps);
    EXPECT_NEAR(sigma.grad()[i].item<double>(), fd, 2e-3 + 2e-2 * std::fabs(fd)) << "sigma " << i;
    for (int k = 0; k < 3; ++k) {
      auto cp = rgb.detach().clone(), cm = rgb.detach().clone();
      cp[i][k] += eps;
      cm[i][k] -= eps;
      const double fdc = (objective(sigma.detach(), cp) - objective(sigma.detach(), cm)).item<double>() / (2 * eps);
      EXPECT_NEAR(rgb.grad()[i][k].item<double>(), fdc, 1e-3 + 1e-2 * std::fabs(fdc));
    }
  }
}

TEST(Compositing, StopsOnceOpaque) {
  auto sigma = torch::tensor({1000.0f, 5.0f, 5.0f});
  auto rgb = torch::tensor({{1.0f, 0.0f, 0.0f}, {0.0f, 1.0f, 0.0f}, {0.0f, 0.0f, 1.0f}});
  auto dt = torch::full({3}, 0.1f), t = torch::tensor({1.0f, 1.1f, 1.2f});
  auto offsets = torch::tensor({0, 3}, torch::kInt64);
  auto r = volumeRender(sigma, rgb, dt, t, offsets, torch::zeros({1, 3}), 1e-4);
  EXPECT_NEAR(r.color[0][0].item<float>(), 1.0f, 1e-4);
  EXPECT_NEAR(r.color[0][1].item<float>(), 0.0f, 1e-6);  // later samples are never reached
  EXPECT_NEAR(r.opacity[0].item<float>(), 1.0f, 1e-4);
}

NerfConfig chunkConfig() {
  NerfConfig config;
  config.hash = smallGrid();
  config.field.density_hidden = 16;
  config.field.color_hidden = 16;
  // The float table: the finite differences below perturb table entries by 1e-3, which a
  // half-precision copy would round away (HashEncoding.HalfTable* test that path).
  config.hash.half_table = false;
  return config;
}

/// A small field with table values larger than the default init (so the MLPs see non-trivial
/// inputs), n random unit-cube points and directions, and the weights of a linear objective
/// sum(wsig * sigma + wrgb . rgb) whose gradient is the backward's input.
struct ChunkProblem {
  static constexpr int n = 16;
  NgpField field{chunkConfig(), Box(), 1.0, 11};
  std::vector<float> unit = std::vector<float>(3 * n), dirs = std::vector<float>(3 * n);
  std::vector<float> wsig = std::vector<float>(n), wrgb = std::vector<float>(3 * n);

  ChunkProblem() {
    std::mt19937 rng(13);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    for (float& v : field.table()) v = u(rng);
    field.refreshTransposed();
    std::uniform_real_distribution<float> u01(0.05f, 0.95f);
    for (int i = 0; i < n; ++i) {
      float d[3] = {u(rng), u(rng), u(rng)};
      const float norm = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
      for (int a = 0; a < 3; ++a) {
        unit[3 * i + a] = u01(rng);
        dirs[3 * i + a] = d[a] / norm;
        wrgb[3 * i + a] = u(rng);
      }
      wsig[i] = u(rng) * 0.1f;
    }
  }

  /// The objective through the chunk forward, for finite differences.
  double objective() const {
    FieldWorkspace ws;
    std::vector<float> sigma(n), rgb(3 * n);
    field.forwardChunk(unit.data(), dirs.data(), n, ws, sigma.data(), rgb.data());
    double total = 0;
    for (int i = 0; i < n; ++i) {
      total += wsig[i] * sigma[i];
      for (int k = 0; k < 3; ++k) total += wrgb[3 * i + k] * rgb[3 * i + k];
    }
    return total;
  }
};

/// The objective's gradients with respect to each weight matrix and the encoding, from the same
/// network in double-precision torch ops with autograd (exact, no finite-difference trouble at
/// ReLU kinks).
struct ReferenceGradients {
  std::vector<torch::Tensor> density, color;
  torch::Tensor encoding;
};

ReferenceGradients torchReference(const ChunkProblem& p) {
  const int n = ChunkProblem::n;
  const NgpField& field = p.field;
  const HashGridLayout& hl = field.hashLayout();
  std::vector<float> enc(n * hl.outputDims()), sh(16 * n);
  hashEncodeForward(hl, field.table().data(), p.unit.data(), n, enc.data());
  for (int i = 0; i < n; ++i) shEncode(4, p.dirs[3 * i], p.dirs[3 * i + 1], p.dirs[3 * i + 2], sh.data() + 16 * i);
  auto asTensor = [](const float* data, std::int64_t rows, std::int64_t cols) {
    return torch::from_blob(const_cast<float*>(data), {rows, cols}, torch::kFloat32).to(torch::kFloat64);
  };
  auto encT = asTensor(enc.data(), n, hl.outputDims()).requires_grad_(true);
  std::vector<torch::Tensor> dw, cw;
  const MlpLayout& dl = field.densityLayout();
  const MlpLayout& cl = field.colorLayout();
  for (int l = 0; l < dl.layers(); ++l)
    dw.push_back(asTensor(field.densityWeights().data() + dl.offset(l), dl.dims[l], dl.dims[l + 1]).requires_grad_(true));
  for (int l = 0; l < cl.layers(); ++l)
    cw.push_back(asTensor(field.colorWeights().data() + cl.offset(l), cl.dims[l], cl.dims[l + 1]).requires_grad_(true));
  torch::Tensor h = encT;
  for (int l = 0; l < dl.layers(); ++l) {
    h = h.mm(dw[l]);
    if (l + 1 < dl.layers()) h = h.relu();
  }
  auto sigmaT = h.select(1, 0).clamp_max(15).exp();
  torch::Tensor c = torch::cat({h, asTensor(sh.data(), n, 16)}, 1);
  for (int l = 0; l < cl.layers(); ++l) {
    c = c.mm(cw[l]);
    if (l + 1 < cl.layers()) c = c.relu();
  }
  auto rgbT = c.sigmoid();
  auto loss = (sigmaT * asTensor(p.wsig.data(), n, 1).squeeze(1)).sum() + (rgbT * asTensor(p.wrgb.data(), n, 3)).sum();
  loss.backward();
  ReferenceGradients out;
  for (auto& w : dw) out.density.push_back(w.grad());
  for (auto& w : cw) out.color.push_back(w.grad());
  out.encoding = encT.grad();
  return out;
}

void expectMatches(const torch::Tensor& reference, const float* ours, const char* name) {
  auto flat = reference.contiguous().view(-1);
  for (std::int64_t i = 0; i < flat.numel(); ++i) {
    const double r = flat[i].item<double>();
    ASSERT_NEAR(ours[i], r, 1e-5 + 1e-3 * std::fabs(r)) << name << " element " << i;
  }
}

// The fused field backward (MLPs + sigmoid + trunc_exp) against an autograd reference of the
// chunk forward, for weights of both networks and for the encoding input.
TEST(NgpField, ChunkBackwardMatchesFiniteDifferences) {
  ChunkProblem p;
  NgpField& field = p.field;
  const int n = ChunkProblem::n;
  FieldWorkspace ws;
  std::vector<float> sigma(n), rgb(3 * n), genc(n * field.hashLayout().outputDims());
  field.forwardChunk(p.unit.data(), p.dirs.data(), n, ws, sigma.data(), rgb.data());
  MlpGradients grads;
  grads.density.assign(field.densityWeights().size(), 0.0f);
  grads.color.assign(field.colorWeights().size(), 0.0f);
  field.backwardChunk(n, ws, p.wsig.data(), p.wrgb.data(), grads, genc.data());

  const ReferenceGradients reference = torchReference(p);
  const MlpLayout& dl = field.densityLayout();
  const MlpLayout& cl = field.colorLayout();
  for (int l = 0; l < dl.layers(); ++l) {
    expectMatches(reference.density[l], grads.density.data() + dl.offset(l), "density weights");
  }
  for (int l = 0; l < cl.layers(); ++l) {
    expectMatches(reference.color[l], grads.color.data() + cl.offset(l), "colour weights");
  }
  expectMatches(reference.encoding, genc.data(), "encoding");

  // Encoding gradient, chained through the table: d/d(entry) = sum over points of
  // grad_encoding * trilinear weight, which the table backward computes.
  std::vector<float> table_grad(field.table().size(), 0.0f);
  const HashGridLayout& layout = field.hashLayout();
  hashEncodeBackwardTable(layout, p.unit.data(), n, genc.data(), table_grad.data(), 0, layout.levels);
  std::vector<float>& table = field.table();
  const float eps = 1e-3f;
  int checked = 0;
  for (std::size_t i = 0; i < table.size() && checked < 40; i += 3) {
    if (table_grad[i] == 0.0f) continue;
    const float keep = table[i];
    table[i] = keep + eps;
    const double plus = p.objective();
    table[i] = keep - eps;
    const double minus = p.objective();
    table[i] = keep;
    const double fd = (plus - minus) / (2 * eps);
    EXPECT_NEAR(table_grad[i], fd, 3e-3 + 3e-2 * std::fabs(fd)) << "table entry " << i;
    ++checked;
  }
  EXPECT_GT(checked, 10);
}

// The blocked MLP kernels against plain double-precision loops, for every output width they
// specialise (3, 16, 32, 64, 128), a width they do not (20), row counts that leave remainders
// of the row blocks, and input widths that are and are not multiples of the vector width.
TEST(MlpKernels, ProductsMatchPlainLoops) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int out_dims : {3, 16, 20, 32, 64, 128}) {
    for (int in_dims : {16, 32, 35}) {
      for (int n : {1, 13, 256}) {
        std::vector<float> in(n * in_dims), w(in_dims * out_dims), g(n * out_dims), out(n * out_dims);
        for (float& v : in) v = u(rng);
        for (float& v : w) v = u(rng);
        for (float& v : g) v = u(rng);
        std::vector<float> gw(in_dims * out_dims, 0.5f);
        for (bool relu : {false, true}) {
          matmulRows(in.data(), n, in_dims, w.data(), out_dims, out.data(), relu);
          for (int r = 0; r < n; ++r)
            for (int j = 0; j < out_dims; ++j) {
              double want = 0;
              for (int k = 0; k < in_dims; ++k) want += double(in[r * in_dims + k]) * w[k * out_dims + j];
              if (relu) want = std::max(want, 0.0);
              ASSERT_NEAR(out[r * out_dims + j], want, 1e-4) << out_dims << "x" << in_dims << " n " << n;
            }
        }
        accumulateWeightGrad(in.data(), n, in_dims, g.data(), out_dims, gw.data());
        for (int k = 0; k < in_dims; ++k)
          for (int j = 0; j < out_dims; ++j) {
            double want = 0.5;
            for (int r = 0; r < n; ++r) want += double(in[r * in_dims + k]) * g[r * out_dims + j];
            ASSERT_NEAR(gw[k * out_dims + j], want, 1e-3) << out_dims << "x" << in_dims << " n " << n;
          }
      }
    }
  }
}

}  // namespace
}  // namespace demnerf::nerf
