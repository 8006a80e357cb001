#pragma once
// Adam on flat float parameter blocks: dense for the MLPs, and for the hash table only the
// parameters whose gradient is non-zero, as instant-ngp skips table entries no sample reached.

#include <cstdint>
#include <vector>

namespace demnerf::nerf {

struct AdamHyper {
  float learning_rate = 1e-2f, beta1 = 0.9f, beta2 = 0.99f, epsilon = 1e-15f, weight_decay = 0.0f;
  std::int64_t step = 1;  ///< 1-based, for the bias correction
};

struct AdamMoments {
  std::vector<float> m, v;
  void resize(std::size_t n) { m.assign(n, 0.0f); v.assign(n, 0.0f); }
};

/// Updates every parameter and zeroes its gradient. Threaded.
void adamDense(const AdamHyper& h, float* params, float* grads, AdamMoments& moments, std::int64_t n);
/// On the calling thread: updates the parameters in [begin, end) (floats, not entries) whose
/// gradient is non-zero and zeroes the gradients, as instant-ngp's optimiser treats the hash
/// table: an entry no sample reached, or whose gradients cancelled, keeps its value and
/// moments. Needs no touched flags, so the scatter writes only gradients; 16 parameters per
/// step where the build has AVX-512. `half`, when not null, is the half-precision copy of
/// params (NgpField::halfTable()) and gets every updated value.
void adamNonzero(const AdamHyper& h, float* params, float* grads, AdamMoments& moments, std::int64_t begin,
                 std::int64_t end, std::uint16_t* half = nullptr);

}  // namespace demnerf::nerf
