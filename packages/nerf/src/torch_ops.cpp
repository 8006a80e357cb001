#include "demnerf/nerf/torch_ops.hpp"

#include <ATen/Parallel.h>

#include "demnerf/core/error.hpp"
#include "demnerf/nerf/compositing.hpp"

namespace demnerf::nerf {
namespace {

using torch::autograd::AutogradContext;
using torch::autograd::tensor_list;

void requireFloat(const torch::Tensor& t, const char* name) {
  if (t.device().type() != torch::kCPU || t.scalar_type() != torch::kFloat32) {
    throw core::Error(std::string(name) + " must be a float32 CPU tensor");
  }
}

class HashEncodeFunction : public torch::autograd::Function<HashEncodeFunction> {
 public:
  static torch::Tensor forward(AutogradContext* ctx, torch::Tensor positions, torch::Tensor table,
                               const HashGridLayout* layout) {
    positions = positions.contiguous();
    table = table.contiguous();
    const std::int64_t n = positions.size(0);
    auto out = torch::empty({n, layout->outputDims()}, positions.options());
    const float* p = positions.data_ptr<float>();
    const float* tab = table.data_ptr<float>();
    float* o = out.data_ptr<float>();
    at::parallel_for(0, n, 256, [&](std::int64_t begin, std::int64_t end) {
      hashEncodeForward(*layout, tab, p + 3 * begin, end - begin, o + begin * layout->outputDims());
    });
    ctx->save_for_backward({positions, table});
    ctx->saved_data["layout"] = reinterpret_cast<std::int64_t>(layout);
    return out;
  }

  static tensor_list backward(AutogradContext* ctx, tensor_list grads) {
    const auto saved = ctx->get_saved_variables();
    const torch::Tensor& positions = saved[0];
    const torch::Tensor& table = saved[1];
    const auto* layout = reinterpret_cast<const HashGridLayout*>(ctx->saved_data["layout"].toInt());
    const torch::Tensor grad_out = grads[0].contiguous();
    const std::int64_t n = positions.size(0);
    torch::Tensor grad_table, grad_positions;
    if (ctx->needs_input_grad(1)) {
      grad_table = torch::zeros_like(table);
      // Levels write disjoint table ranges: threads split the levels, no atomics needed.
      at::parallel_for(0, layout->levels, 1, [&](std::int64_t begin, std::int64_t end) {
        hashEncodeBackwardTable(*layout, positions.data_ptr<float>(), n, grad_out.data_ptr<float>(),
                                grad_table.data_ptr<float>(), static_cast<int>(begin), static_cast<int>(end));
      });
    }
    if (ctx->needs_input_grad(0)) {
      grad_positions = torch::empty_like(positions);
      at::parallel_for(0, n, 256, [&](std::int64_t begin, std::int64_t end) {
        hashEncodeBackwardPositions(*layout, table.data_ptr<float>(), positions.data_ptr<float>() + 3 * begin,
                                    end - begin, grad_out.data_ptr<float>() + begin * layout->outputDims(),
                                    grad_positions.data_ptr<float>() + 3 * begin);
      });
    }
    return {grad_positions, grad_table, torch::Tensor()};
  }
};

class VolumeRenderFunction : public torch::autograd::Function<VolumeRenderFunction> {
 public:
  static tensor_list forward(AutogradContext* ctx, torch::Tensor sigma, torch::Tensor rgb, torch::Tensor dt,
                             torch::Tensor t, torch::Tensor offsets, torch::Tensor background, double min_t) {
    sigma = sigma.contiguous();
    rgb = rgb.contiguous();
    dt = dt.contiguous();
    t = t.contiguous();
    offsets = offsets.contiguous();
    background = background.contiguous();
    const std::int64_t rays = offsets.size(0) - 1;
    auto color = torch::empty({rays, 3}, sigma.options());
    auto opacity = torch::empty({rays}, sigma.options());
    auto depth = torch::empty({rays}, sigma.options());
    CompositeInputs in{sigma.data_ptr<float>(), rgb.data_ptr<float>(), dt.data_ptr<float>(), t.data_ptr<float>(),
                       offsets.data_ptr<std::int64_t>(), rays, background.data_ptr<float>(), static_cast<float>(min_t)};
    compositeForward(in, {color.data_ptr<float>(), opacity.data_ptr<float>(), depth.data_ptr<float>()});
    ctx->save_for_backward({sigma, rgb, dt, t, offsets, background, color, opacity, depth});
    ctx->saved_data["min_t"] = min_t;
    return {color, opacity, depth};
  }

  static tensor_list backward(AutogradContext* ctx, tensor_list grads) {
    const auto s = ctx->get_saved_variables();
    const std::int64_t rays = s[4].size(0) - 1;
    CompositeInputs in{s[0].data_ptr<float>(), s[1].data_ptr<float>(), s[2].data_ptr<float>(), s[3].data_ptr<float>(),
                       s[4].data_ptr<std::int64_t>(), rays, s[5].data_ptr<float>(),
                       static_cast<float>(ctx->saved_data["min_t"].toDouble())};
    CompositeOutputs fwd{s[6].data_ptr<float>(), s[7].data_ptr<float>(), s[8].data_ptr<float>()};
    torch::Tensor gc = grads[0].defined() ? grads[0].contiguous() : torch::Tensor();
    torch::Tensor go = grads[1].defined() ? grads[1].contiguous() : torch::Tensor();
    torch::Tensor gd = grads[2].defined() ? grads[2].contiguous() : torch::Tensor();
    auto grad_sigma = torch::empty_like(s[0]);
    auto grad_rgb = torch::empty_like(s[1]);
    compositeBackward(in, fwd, gc.defined() ? gc.data_ptr<float>() : nullptr,
                      go.defined() ? go.data_ptr<float>() : nullptr, gd.defined() ? gd.data_ptr<float>() : nullptr,
                      grad_sigma.data_ptr<float>(), grad_rgb.data_ptr<float>());
    return {grad_sigma, grad_rgb, torch::Tensor(), torch::Tensor(), torch::Tensor(), torch::Tensor(), torch::Tensor()};
  }
};

}  // namespace

torch::Tensor hashEncode(const torch::Tensor& positions, const torch::Tensor& table, const HashGridLayout& layout) {
  requireFloat(positions, "hashEncode positions");
  requireFloat(table, "hashEncode table");
  if (positions.dim() != 2 || positions.size(1) != 3) throw core::Error("hashEncode positions must be [N,3]");
  if (table.numel() != layout.parameterCount()) {
    throw core::Error("hashEncode table has " + std::to_string(table.numel()) + " values, layout needs " +
                      std::to_string(layout.parameterCount()));
  }
  return HashEncodeFunction::apply(positions, table, &layout);
}

VolumeRenderResult volumeRender(const torch::Tensor& sigma, const torch::Tensor& rgb, const torch::Tensor& dt,
                                const torch::Tensor& t, const torch::Tensor& ray_offsets,
                                const torch::Tensor& background, double min_transmittance) {
  requireFloat(sigma, "volumeRender sigma");
  requireFloat(rgb, "volumeRender rgb");
  requireFloat(dt, "volumeRender dt");
  requireFloat(t, "volumeRender t");
  requireFloat(background, "volumeRender background");
  if (ray_offsets.scalar_type() != torch::kInt64) throw core::Error("volumeRender ray_offsets must be int64");
  const std::int64_t s = sigma.numel();
  if (rgb.numel() != 3 * s || dt.numel() != s || t.numel() != s) {
    throw core::Error("volumeRender: sigma, rgb, dt and t must describe the same " + std::to_string(s) + " samples");
  }
  const std::int64_t rays = ray_offsets.numel() - 1;
  if (rays < 0 || background.numel() != 3 * rays) throw core::Error("volumeRender: background must be [R,3]");
  auto out = VolumeRenderFunction::apply(sigma, rgb, dt, t, ray_offsets, background, min_transmittance);
  return {out[0], out[1], out[2]};
}

}  // namespace demnerf::nerf
