// Kernel micro-benchmarks: the machine's sgemm GFLOP/s (LibTorch's BLAS) next to the NeRF's
// own small-MLP kernel and the hash encoding, for a fraction-of-peak figure.
//   nerf_kernels [--threads N]

#include <ATen/Parallel.h>
#include <torch/torch.h>

#include <chrono>
#include <cstdio>
#include <random>
#include <thread>

#include "demnerf/nerf/hash_encoding.hpp"
#include "demnerf/nerf/mlp.hpp"

using namespace demnerf::nerf;
using Clock = std::chrono::steady_clock;

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
