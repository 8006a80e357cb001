#include "demnerf/nerf/adam.hpp"

#include <ATen/Parallel.h>

#include <cmath>
#if defined(__F16C__) || defined(__AVX512F__)
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

namespace {

// Sixteen parameters at a time; only the lanes whose gradient is non-zero are written.
// Returns the first index it did not take (the caller's scalar loop does the rest).
inline std::int64_t adamNonzeroVector(const Step& s, float* params, float* grads, float* m, float* v,
                                      std::int64_t begin, std::int64_t end, std::uint16_t* half) {
  std::int64_t i = begin;
#if defined(__AVX512F__) && defined(__AVX512BW__) && defined(__AVX512VL__)
  const __m512 zero = _mm512_setzero_ps();
  const __m512 b1 = _mm512_set1_ps(s.b1), one_b1 = _mm512_set1_ps(1.0f - s.b1);
  const __m512 b2 = _mm512_set1_ps(s.b2), one_b2 = _mm512_set1_ps(1.0f - s.b2);
  const __m512 lr = _mm512_set1_ps(s.lr_hat), eps = _mm512_set1_ps(s.eps), decay = _mm512_set1_ps(s.decay);
  for (; i + 16 <= end; i += 16) {
    const __m512 g = _mm512_loadu_ps(grads + i);
    const __mmask16 live = _mm512_cmp_ps_mask(g, zero, _CMP_NEQ_UQ);
    if (!live) continue;  // untouched this step: the fine levels' entries no sample reached
    const __m512 p = _mm512_loadu_ps(params + i);
    // The same operations, in the same order, as Step::apply.
    const __m512 grad = _mm512_add_ps(g, _mm512_mul_ps(decay, p));
    const __m512 mi = _mm512_add_ps(_mm512_mul_ps(b1, _mm512_loadu_ps(m + i)), _mm512_mul_ps(one_b1, grad));
    const __m512 vi = _mm512_add_ps(_mm512_mul_ps(b2, _mm512_loadu_ps(v + i)),
                                    _mm512_mul_ps(_mm512_mul_ps(one_b2, grad), grad));
    const __m512 step = _mm512_div_ps(_mm512_mul_ps(lr, mi), _mm512_add_ps(_mm512_sqrt_ps(vi), eps));
    const __m512 pi = _mm512_sub_ps(p, step);
    _mm512_mask_storeu_ps(m + i, live, mi);
    _mm512_mask_storeu_ps(v + i, live, vi);
    _mm512_mask_storeu_ps(params + i, live, pi);
    _mm512_storeu_ps(grads + i, zero);
    if (half) {
      const __m256i h = _mm512_cvtps_ph(pi, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
      _mm256_mask_storeu_epi16(half + i, live, h);
    }
  }
#else
  (void)s, (void)params, (void)grads, (void)m, (void)v, (void)end, (void)half;
#endif
  return i;
}

}  // namespace

void adamNonzero(const AdamHyper& h, float* params, float* grads, AdamMoments& moments, std::int64_t begin,
                 std::int64_t end, std::uint16_t* half) {
  const Step s(h);
  float* m = moments.m.data();
  float* v = moments.v.data();
  for (std::int64_t i = adamNonzeroVector(s, params, grads, m, v, begin, end, half); i < end; ++i) {
    if (grads[i] == 0.0f) continue;
    s.apply(params[i], grads[i], m[i], v[i]);
#if defined(__F16C__)
    if (half) half[i] = _cvtss_sh(params[i], _MM_FROUND_TO_NEAREST_INT);
#endif
  }
}

}  // namespace demnerf::nerf
