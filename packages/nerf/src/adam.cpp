#include "demnerf/nerf/adam.hpp"

#include <ATen/Parallel.h>

#include <cmath>
#if defined(__F16C__)
#include <immintrin.h>
#endif

namespace demnerf::nerf {
namespace {

struct Step {
  float lr_hat, b1, b2, eps, decay;
  explicit Step(const AdamHyper& h)
      : lr_hat(h.learning_rate * std::sqrt(1.0f - std::pow(h.beta2, static_cast<float>(h.step))) /
               (1.0f - std::pow(h.beta1, static_cast<float>(h.step)))),
        b1(h.beta1), b2(h.beta2), eps(h.epsilon), decay(h.weight_decay) {}
  inline void apply(float& p, float& g, float& m, float& v) const {
    const float grad = g + decay * p;
    m = b1 * m + (1.0f - b1) * grad;
    v = b2 * v + (1.0f - b2) * grad * grad;
    p -= lr_hat * m / (std::sqrt(v) + eps);
    g = 0.0f;
  }
};

}  // namespace

void adamDense(const AdamHyper& h, float* params, float* grads, AdamMoments& moments, std::int64_t n) {
  const Step s(h);
  float* m = moments.m.data();
  float* v = moments.v.data();
  at::parallel_for(0, n, 4096, [&](std::int64_t begin, std::int64_t end) {
    for (std::int64_t i = begin; i < end; ++i) s.apply(params[i], grads[i], m[i], v[i]);
  });
}

void adamSparse(const AdamHyper& h, float* params, float* grads, AdamMoments& moments,
                const std::vector<std::int64_t>& entries, int features, std::uint8_t* touched) {
  const Step s(h);
  float* m = moments.m.data();
  float* v = moments.v.data();
  at::parallel_for(0, static_cast<std::int64_t>(entries.size()), 2048, [&](std::int64_t begin, std::int64_t end) {
    for (std::int64_t k = begin; k < end; ++k) {
      const std::int64_t e = entries[k];
      touched[e] = 0;
      for (int f = 0; f < features; ++f) {
        const std::int64_t i = e * features + f;
        s.apply(params[i], grads[i], m[i], v[i]);
      }
    }
  });
}

void adamTouched(const AdamHyper& h, float* params, float* grads, AdamMoments& moments, std::int64_t begin,
                 std::int64_t end, int features, std::uint8_t* touched, std::uint16_t* half) {
  const Step s(h);
  float* m = moments.m.data();
  float* v = moments.v.data();
  for (std::int64_t e = begin; e < end; ++e) {
    if (!touched[e]) continue;
    touched[e] = 0;
    for (int f = 0; f < features; ++f) {
      const std::int64_t i = e * features + f;
      s.apply(params[i], grads[i], m[i], v[i]);
#if defined(__F16C__)
      // The forward's half copy follows the entries Adam changes, while they are in cache.
      if (half) half[i] = _cvtss_sh(params[i], _MM_FROUND_TO_NEAREST_INT);
#endif
    }
  }
}

}  // namespace demnerf::nerf
