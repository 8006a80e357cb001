#include "demnerf/render/deformed_field.hpp"

#include <ATen/Parallel.h>

#include <algorithm>
#include <vector>

namespace demnerf::render {
namespace {

constexpr int kBlock = 4096;  // points mapped per block: the rest field is asked once per block

/// The compacted rest points of one block (those inside the body), per thread.
struct RestSamples {
  std::vector<float> rest, dirs, sigma, rgb;
  std::vector<int> index;  ///< compacted -> block point
  void reserve() {
    rest.resize(3 * kBlock);
    dirs.resize(3 * kBlock);
    sigma.resize(kBlock);
    rgb.resize(3 * kBlock);
    index.resize(kBlock);
  }
};

}  // namespace

DeformedField::DeformedField(const nerf::NerfModel& model, const TetEmbedding& embedding, const nerf::Box& bounds,
                             bool rotate_directions)
    : model_(model), embedding_(embedding), bounds_(bounds), rotate_(rotate_directions) {}

void DeformedField::queryBlock(const float* points, const float* directions, int n, float* sigma,
                               float* rgb) const {
  thread_local RestSamples rs;
  rs.reserve();
  const nerf::OccupancyGrid& rest_grid = model_.grid();
  int inside = 0;
  for (int s = 0; s < n; ++s) {
    sigma[s] = 0.0f;
    if (rgb) std::fill(rgb + 3 * s, rgb + 3 * s + 3, 0.0f);
    const RestPoint rp = embedding_.locate(points + 3 * s);
    if (rp.tet < 0) continue;
    const std::int64_t cell = rest_grid.cellOf(rp.rest);
    if (cell < 0 || !rest_grid.occupied(cell)) continue;
    std::copy(rp.rest, rp.rest + 3, rs.rest.data() + 3 * inside);
    if (rgb && rotate_) {
      embedding_.restDirection(rp.tet, directions + 3 * s, rs.dirs.data() + 3 * inside);
    } else if (rgb) {
      std::copy(directions + 3 * s, directions + 3 * s + 3, rs.dirs.data() + 3 * inside);
    }
    rs.index[inside++] = s;
  }
  if (inside == 0) return;
  // Called inside a parallel region, the rest field's parallel_for runs inline on this thread.
  if (rgb) {
    model_.field().query(rs.rest.data(), rs.dirs.data(), inside, rs.sigma.data(), rs.rgb.data());
  } else {
    model_.field().density(rs.rest.data(), inside, rs.sigma.data());
  }
  for (int k = 0; k < inside; ++k) {
    const int s = rs.index[k];
    sigma[s] = rs.sigma[k];
    if (rgb) std::copy(rs.rgb.data() + 3 * k, rs.rgb.data() + 3 * k + 3, rgb + 3 * s);
  }
}

void DeformedField::density(const float* points, std::int64_t n, float* sigma) const {
  at::parallel_for(0, (n + kBlock - 1) / kBlock, 1, [&](std::int64_t begin, std::int64_t end) {
    for (std::int64_t b = begin; b < end; ++b) {
      const std::int64_t first = b * kBlock;
      queryBlock(points + 3 * first, nullptr, static_cast<int>(std::min<std::int64_t>(kBlock, n - first)),
                 sigma + first, nullptr);
    }
  });
}

void DeformedField::query(const float* points, const float* directions, std::int64_t n, float* sigma,
                          float* rgb) const {
  at::parallel_for(0, (n + kBlock - 1) / kBlock, 1, [&](std::int64_t begin, std::int64_t end) {
    for (std::int64_t b = begin; b < end; ++b) {
      const std::int64_t first = b * kBlock;
      queryBlock(points + 3 * first, directions + 3 * first,
                 static_cast<int>(std::min<std::int64_t>(kBlock, n - first)), sigma + first, rgb + 3 * first);
    }
  });
}

}  // namespace demnerf::render
