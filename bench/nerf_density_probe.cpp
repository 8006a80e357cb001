// Where a model's density lies in a box, by what the training cameras could see of it: the
// density is sampled on a lattice over the box, and for every node the light that reaches it
// from each training camera (the model's own density along the segment inside the box) is
// marched; a node counts as seen when some camera still has min_t of its light there. Dense
// nodes that no camera sees were never fit by a training ray (behind surfaces, or in space
// every view's ray had stopped before); a model that fills them extracts as a blob.
//   nerf_density_probe --model M.nerf --data DIR [--box x0,y0,z0,x1,y1,z1] [--resolution 64]
//                      [--threshold 20] [--min-transmittance 0.01]

#include <ATen/Parallel.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "demnerf/core/dataset.hpp"
#include "demnerf/nerf/model_io.hpp"

using namespace demnerf;

namespace {

struct Lattice {
  float lo[3], h;
  int n[3];
  std::vector<float> sigma;
  float at(const float* p) const {  // trilinear on node values, zero outside
    float u[3];
    int i[3];
    for (int a = 0; a < 3; ++a) {
      u[a] = (p[a] - lo[a]) / h - 0.5f;
      if (u[a] < 0.0f || u[a] > n[a] - 1.0f) return 0.0f;
      i[a] = std::min(static_cast<int>(u[a]), n[a] - 2);
      u[a] -= i[a];
    }
    float s = 0.0f;
    for (int c = 0; c < 8; ++c) {
      const int dx = c & 1, dy = (c >> 1) & 1, dz = c >> 2;
      const float w = (dx ? u[0] : 1 - u[0]) * (dy ? u[1] : 1 - u[1]) * (dz ? u[2] : 1 - u[2]);
      s += w * sigma[(static_cast<std::size_t>(i[2] + dz) * n[1] + i[1] + dy) * n[0] + i[0] + dx];
    }
    return s;
  }
};

/// Light left at p from a camera at o: the lattice's density along the part of o -> p inside the box.
float lightAt(const Lattice& g, const float* o, const float* p) {
  float d[3], len = 0.0f;
  for (int a = 0; a < 3; ++a) len += (d[a] = p[a] - o[a]) * d[a];
  len = std::sqrt(len);
  for (float& v : d) v /= len;
  float t0 = 0.0f;
  for (int a = 0; a < 3; ++a) {  // entry into the box
    if (std::fabs(d[a]) < 1e-9f) continue;
    const float lo = g.lo[a], hi = g.lo[a] + g.n[a] * g.h;
    t0 = std::max(t0, std::min((lo - o[a]) / d[a], (hi - o[a]) / d[a]));
  }
  const float step = 0.5f * g.h, stop = len - g.h;  // up to a cell in front of the node
  double depth = 0.0;
  for (float t = t0 + 0.5f * step; t < stop; t += step) {
    const float q[3] = {o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]};
    depth += g.at(q) * step;
    if (depth > 12.0) break;
  }
  return static_cast<float>(std::exp(-depth));
}

/// Volumes of the dense nodes by the light the cameras bring them, in all and by x slab.
void report(const Lattice& g, const std::vector<float>& seen, std::size_t cameras, float threshold, float min_t) {
  const std::size_t nodes = g.sigma.size();
  const double cell = static_cast<double>(g.h) * g.h * g.h;
  double dense_seen = 0, dense_edge = 0, dense_hidden = 0, hidden = 0;
  std::vector<double> slab_hidden(8, 0.0), slab_seen(8, 0.0);
  for (std::size_t k = 0; k < nodes; ++k) {
    const bool dense = g.sigma[k] > threshold;
    const int slab = std::min(7, static_cast<int>(8 * (k % g.n[0]) / g.n[0]));
    if (seen[k] < min_t) hidden += cell;
    if (!dense) continue;
    if (seen[k] >= 0.5f) dense_seen += cell;
    else if (seen[k] >= min_t) dense_edge += cell;
    else dense_hidden += cell;
    (seen[k] < min_t ? slab_hidden : slab_seen)[slab] += cell;
  }
  std::printf("lattice %d x %d x %d (cell %.4f), %zu cameras\n", g.n[0], g.n[1], g.n[2], g.h, cameras);
  std::printf("volume of the box %.3f, seen by no camera with >= %g of its light: %.3f\n",
              nodes * cell, min_t, hidden);
  std::printf("density > %g: %.3f in all; seen (light >= 0.5) %.3f, surface layer (%g..0.5) %.3f, hidden %.3f\n",
              threshold, dense_seen + dense_edge + dense_hidden, dense_seen, min_t, dense_edge, dense_hidden);
  std::printf("dense volume by x slab (low x = wall side): hidden");
  for (double v : slab_hidden) std::printf(" %.3f", v);
  std::printf("\n                                          seen  ");
  for (double v : slab_seen) std::printf(" %.3f", v);
  std::printf("\n");
}

}  // namespace

int main(int argc, char** argv) {
  std::map<std::string, std::string> args;
  for (int i = 1; i + 1 < argc; i += 2) args[std::string(argv[i]).substr(2)] = argv[i + 1];
  const auto get = [&](const char* k, const char* d) { return args.count(k) ? args[k] : std::string(d); };
  if (!args.count("model") || !args.count("data")) {
    std::fprintf(stderr, "usage: nerf_density_probe --model M.nerf --data DIR [--box x0,y0,z0,x1,y1,z1] "
                         "[--resolution 64] [--threshold 20] [--min-transmittance 0.01]\n");
    return 2;
  }
  try {
    at::set_num_threads(static_cast<int>(std::max(1u, std::thread::hardware_concurrency())));
    core::DatasetOptions options;
    options.load_images = false;
    const core::Dataset dataset = core::loadDataset(args["data"], options);
    const nerf::NerfModel model = nerf::loadModel(args["model"]);
    float box[6];
    std::sscanf(get("box", "0.45,-1.5,-1.2,2.0,0.3,1.45").c_str(), "%f,%f,%f,%f,%f,%f", box, box + 1, box + 2,
                box + 3, box + 4, box + 5);
    const int res = std::stoi(get("resolution", "64"));
    const float threshold = std::stof(get("threshold", "20")), min_t = std::stof(get("min-transmittance", "0.01"));
    Lattice g;
    float longest = 0.0f;
    for (int a = 0; a < 3; ++a) longest = std::max(longest, box[3 + a] - box[a]);
    g.h = longest / res;
    for (int a = 0; a < 3; ++a) {
      g.lo[a] = box[a];
      g.n[a] = std::max(2, static_cast<int>(std::lround((box[3 + a] - box[a]) / g.h)));
    }
    const std::size_t nodes = static_cast<std::size_t>(g.n[0]) * g.n[1] * g.n[2];
    std::vector<float> pts(3 * nodes);
    for (std::size_t k = 0; k < nodes; ++k) {
      const std::size_t idx[3] = {k % g.n[0], (k / g.n[0]) % g.n[1], k / (static_cast<std::size_t>(g.n[0]) * g.n[1])};
      for (int a = 0; a < 3; ++a) pts[3 * k + a] = g.lo[a] + (idx[a] + 0.5f) * g.h;
    }
    g.sigma.resize(nodes);
    model.field().density(pts.data(), static_cast<std::int64_t>(nodes), g.sigma.data());
    std::vector<float> seen(nodes, 0.0f);
    const std::vector<core::Frame>& cams = dataset.train;
    at::parallel_for(0, static_cast<std::int64_t>(nodes), 256, [&](std::int64_t b, std::int64_t e) {
      for (std::int64_t k = b; k < e; ++k) {
        const float* p = pts.data() + 3 * k;
        for (const core::Frame& f : cams) {
          const Eigen::Vector3d local = f.world_from_camera.inverse() * Eigen::Vector3d(p[0], p[1], p[2]);
          if (local.z() <= 0) continue;
          const double u = f.camera.fx * local.x() / local.z() + f.camera.cx;
          const double v = f.camera.fy * local.y() / local.z() + f.camera.cy;
          if (u < 0 || v < 0 || u > f.camera.width || v > f.camera.height) continue;
          float o[3];
          for (int a = 0; a < 3; ++a) o[a] = static_cast<float>(f.world_from_camera.translation()[a]);
          seen[k] = std::max(seen[k], lightAt(g, o, p));
          if (seen[k] >= 0.5f) break;
        }
      }
    });
    report(g, seen, cams.size(), threshold, min_t);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "nerf_density_probe: %s\n", e.what());
    return 1;
  }
  return 0;
}
