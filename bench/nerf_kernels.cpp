// Kernel micro-benchmarks: the machine's sgemm GFLOP/s (LibTorch's BLAS) next to the NeRF's
// own small-MLP kernel and the hash encoding, for a fraction-of-peak figure.
//   nerf_kernels [--threads N] | [--field]   (--field: only the per-sample field costs)

#include <ATen/Parallel.h>
#include <torch/torch.h>

#include <chrono>
#include <cstdio>
#include <random>
#include <thread>

#include <ctime>

#include "demnerf/nerf/adam.hpp"
#include "demnerf/nerf/hash_encoding.hpp"
#include "demnerf/nerf/mlp.hpp"
#include "demnerf/nerf/ngp_field.hpp"

using namespace demnerf::nerf;
using Clock = std::chrono::steady_clock;

/// CPU seconds of the calling thread: per-sample costs that other jobs on a shared machine
/// inflate far less than wall time.
double threadSeconds() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

/// The training step's table scatter: one level at a time over a whole batch (2^14 samples),
/// reading the encoding gradient row-major (128-byte stride, as before) or level-major.
void batchScatterCosts(const NgpField& field, const std::vector<float>& unit) {
  const HashGridLayout& layout = field.hashLayout();
  const int dims = layout.outputDims(), F = layout.features;
  const std::int64_t n = 1 << 14;
  std::vector<float> rows(n * dims), levels(n * dims), grad(field.table().size(), 0.0f);
  std::vector<std::uint8_t> touched(layout.total_entries, 0);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> g(-1e-3f, 1e-3f);
  for (float& v : rows) v = g(rng);
  for (int l = 0; l < layout.levels; ++l)
    for (std::int64_t i = 0; i < n; ++i)
      for (int f = 0; f < F; ++f) levels[(l * n + i) * F + f] = rows[i * dims + l * F + f];
  double row_major = 1e30, level_major = 1e30;
  for (int repeat = 0; repeat < 3; ++repeat) {
    double t0 = threadSeconds();
    for (int l = 0; l < layout.levels; ++l)
      hashEncodeBackwardLevel(layout, unit.data(), n, rows.data() + l * F, dims, grad.data(), l, touched.data());
    const double t1 = threadSeconds();
    for (int l = 0; l < layout.levels; ++l)
      hashEncodeBackwardLevel(layout, unit.data(), n, levels.data() + l * n * F, F, grad.data(), l, touched.data());
    row_major = std::min(row_major, t1 - t0);
    level_major = std::min(level_major, threadSeconds() - t1);
  }
  std::printf("table_scatter_batch_row_major_us_per_sample %.3f\ntable_scatter_batch_level_major_us_per_sample %.3f\n",
              1e6 * row_major / n, 1e6 * level_major / n);
}

/// The table's Adam sweep as a training step runs it: every entry touched (the fox's case).
void tableAdamCosts(NgpField& field, std::vector<float>& table_grad) {
  AdamMoments moments;
  moments.resize(field.table().size());
  const auto params = static_cast<std::int64_t>(field.table().size());
  double adam = 1e30;
  for (int repeat = 0; repeat < 3; ++repeat) {
    std::fill(table_grad.begin(), table_grad.end(), 1e-3f);
    AdamHyper h;
    h.step = repeat + 1;
    // What training runs: the sweep over non-zero gradients, 16 at a time.
    const double t0 = threadSeconds();
    adamNonzero(h, field.table().data(), table_grad.data(), moments, 0, params, nullptr);
    adam = std::min(adam, threadSeconds() - t0);
  }
  std::printf("table_adam_nonzero_ms_per_step %.2f\n", 1e3 * adam);
}

/// One thread's cost per sample of the field's chunk kernels (the training step's forward and
/// backward, the renderer's query) in thread-CPU microseconds, on the fox's field (2^17-entry
/// tables, finest level 2048) at points spread like one round of rays: runs of 8 along lines.
void fieldCosts() {
  demnerf::nerf::NerfConfig config;
  config.hash.log2_table_size = 17;
  const demnerf::nerf::Box box;
  demnerf::nerf::NgpField field(config, box, 4.0, 1);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.0f, 1.0f), signed_unit(-1.0f, 1.0f);
  for (float& v : field.table()) v = 1e-2f * signed_unit(rng);
  field.refreshTransposed();  // the half copy the forward reads
  const int n = NgpField::kChunk, chunks = 200;
  std::vector<float> unit(3 * n * chunks), dirs(3 * n * chunks);
  for (int s = 0; s < n * chunks; s += 8) {
    float p[3] = {0.2f + 0.6f * u(rng), 0.2f + 0.6f * u(rng), 0.2f + 0.6f * u(rng)}, d[3], norm = 0;
    for (float& v : d) norm += (v = signed_unit(rng)) * v;
    for (int i = 0; i < 8; ++i)
      for (int a = 0; a < 3; ++a) {
        unit[3 * (s + i) + a] = p[a] + 0.01f * i * d[a] / std::sqrt(norm);
        dirs[3 * (s + i) + a] = d[a] / std::sqrt(norm);
      }
  }
  demnerf::nerf::FieldWorkspace ws;
  demnerf::nerf::MlpGradients grads;
  grads.density.assign(field.densityWeights().size(), 0.0f);
  grads.color.assign(field.colorWeights().size(), 0.0f);
  std::vector<float> sigma(n), rgb(3 * n), gs(n, 1e-3f), grgb(3 * n, 1e-3f), genc(n * field.hashLayout().outputDims());
  std::vector<float> table_grad(field.table().size(), 0.0f);
  double forward = 1e30, backward = 1e30, table = 1e30, encode = 1e30, encode_half = 1e30;
  const std::uint16_t* half = field.halfTable();  // what forwardChunk reads when not null
  for (int repeat = 0; repeat < 3; ++repeat) {
    double f = 0, b = 0, t = 0, e = 0, eh = 0;
    for (int c = 0; c < chunks; ++c) {
      const float* pu = unit.data() + 3 * n * c;
      double t0 = threadSeconds();
      field.forwardChunk(pu, dirs.data() + 3 * n * c, n, ws, sigma.data(), rgb.data());
      double t1 = threadSeconds();
      field.backwardChunk(n, ws, gs.data(), grgb.data(), grads, genc.data());
      double t2 = threadSeconds();
      hashEncodeBackwardTable(field.hashLayout(), pu, n, genc.data(), table_grad.data(), 0, field.hashLayout().levels);
      const double t3 = threadSeconds();
      hashEncodeForward(field.hashLayout(), field.table().data(), pu, n, genc.data());
      const double t4 = threadSeconds();
      e += t4 - t3;
      if (half) hashEncodeForwardHalf(field.hashLayout(), half, pu, n, genc.data());
      eh += threadSeconds() - t4;
      t += t3 - t2;
      f += t1 - t0;
      b += t2 - t1;
    }
    forward = std::min(forward, f);
    backward = std::min(backward, b);
    table = std::min(table, t);
    encode = std::min(encode, e);
    encode_half = std::min(encode_half, eh);
  }
  tableAdamCosts(field, table_grad);
  const double per = 1e6 / (static_cast<double>(n) * chunks);
  // The field forward reads the half table when there is one: its MLP part subtracts that.
  const double encode_used = half ? encode_half : encode;
  std::printf("field_forward_us_per_sample %.3f\nhash_forward_float_us_per_sample %.3f\n"
              "hash_forward_half_us_per_sample %.3f\nfield_forward_mlp_part_us %.3f\n"
              "field_backward_mlp_us_per_sample %.3f\nfield_backward_table_us_per_sample %.3f\n",
              forward * per, encode * per, half ? encode_half * per : 0.0, (forward - encode_used) * per,
              backward * per, table * per);
  batchScatterCosts(field, unit);
}

template <typename F>
double bestSeconds(F f, int repeats = 5) {
  double best = 1e30;
  for (int r = 0; r < repeats; ++r) {
    auto s = Clock::now();
    f();
    best = std::min(best, std::chrono::duration<double>(Clock::now() - s).count());
  }
  return best;
}

int main(int argc, char** argv) {
  int threads = static_cast<int>(std::thread::hardware_concurrency());
  if (argc == 3 && std::string(argv[1]) == "--threads") threads = std::stoi(argv[2]);
  at::set_num_threads(threads);
  std::printf("threads %d\n", threads);
  fieldCosts();
  if (argc == 2 && std::string(argv[1]) == "--field") return 0;
  for (int size : {256, 1024}) {
    auto a = torch::rand({size, size}), b = torch::rand({size, size});
    const double s = bestSeconds([&] { auto c = torch::mm(a, b); });
    std::printf("sgemm_%d_gflops %.1f\n", size, 2.0 * size * size * size / s * 1e-9);
  }
  // The shape a 64-wide MLP layer has during training: (65536 x 64) * (64 x 64).
  const std::int64_t rows = 65536;
  {
    auto a = torch::rand({rows, 64}), b = torch::rand({64, 64});
    const double s = bestSeconds([&] { auto c = torch::mm(a, b); });
    std::printf("sgemm_65536x64x64_gflops %.1f\n", 2.0 * rows * 64 * 64 / s * 1e-9);
  }
  std::vector<float> in(rows * 64), w(64 * 64), out(rows * 64), gw(64 * 64);
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(-1, 1);
  for (float& v : in) v = u(rng);
  for (float& v : w) v = u(rng);
  const double s_fwd = bestSeconds([&] {
    at::parallel_for(0, rows / 256, 1, [&](std::int64_t b, std::int64_t e) {
      for (std::int64_t c = b; c < e; ++c) matmulRows(in.data() + c * 256 * 64, 256, 64, w.data(), 64, out.data() + c * 256 * 64, true);
    });
  });
  std::printf("mlp_kernel_forward_64x64_gflops %.1f\n", 2.0 * rows * 64 * 64 / s_fwd * 1e-9);
  const double s_wg = bestSeconds([&] {
    at::parallel_for(0, rows / 256, 1, [&](std::int64_t b, std::int64_t e) {
      std::vector<float> local(64 * 64, 0.0f);
      for (std::int64_t c = b; c < e; ++c) accumulateWeightGrad(in.data() + c * 256 * 64, 256, 64, out.data() + c * 256 * 64, 64, local.data());
    });
  });
  std::printf("mlp_kernel_weight_grad_64x64_gflops %.1f\n", 2.0 * rows * 64 * 64 / s_wg * 1e-9);

  HashGridConfig hc;
  for (int log2 : {15, 17, 19}) {
    hc.log2_table_size = log2;
    const HashGridLayout layout = HashGridLayout::make(hc);
    std::vector<float> table(layout.parameterCount(), 0.01f), pos(3 * rows), enc(rows * layout.outputDims());
    for (float& v : pos) v = 0.5f + 0.4f * u(rng);
    const double s = bestSeconds([&] {
      at::parallel_for(0, rows / 256, 1, [&](std::int64_t b, std::int64_t e) {
        for (std::int64_t c = b; c < e; ++c)
          hashEncodeForward(layout, table.data(), pos.data() + 3 * c * 256, 256, enc.data() + c * 256 * layout.outputDims());
      });
    });
    std::vector<float> grad(table.size(), 0.0f);
    const double sb = bestSeconds([&] {
      at::parallel_for(0, layout.levels, 1, [&](std::int64_t b, std::int64_t e) {
        hashEncodeBackwardTable(layout, pos.data(), rows, enc.data(), grad.data(), static_cast<int>(b), static_cast<int>(e));
      });
    });
    std::printf("hash_forward_log2T%d_Mpoints_per_s %.2f\nhash_backward_log2T%d_Mpoints_per_s %.2f\n", log2,
                rows / s * 1e-6, log2, rows / sb * 1e-6);
  }
  return 0;
}
