#pragma once
// Adam on flat float parameter blocks: dense for the MLPs, sparse (touched entries only) for
// the hash table, as instant-ngp skips table entries whose gradient is zero.

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
/// Updates the `features` floats of each listed entry and zeroes their gradients and flags.
void adamSparse(const AdamHyper& h, float* params, float* grads, AdamMoments& moments,
                const std::vector<std::int64_t>& entries, int features, std::uint8_t* touched);
/// On the calling thread: updates the entries in [begin, end) whose touched flag is set and
/// clears the flag (for callers that already split the work). `half`, when not null, is the
/// half-precision copy of params (NgpField::halfTable()) and gets every updated value.
void adamTouched(const AdamHyper& h, float* params, float* grads, AdamMoments& moments, std::int64_t begin,
                 std::int64_t end, int features, std::uint8_t* touched, std::uint16_t* half = nullptr);
/// On the calling thread: updates the parameters in [begin, end) (floats, not entries) whose
/// gradient is non-zero and zeroes the gradients, as instant-ngp's optimiser treats the hash
/// table: an entry no sample reached, or whose gradients cancelled, keeps its value and
/// moments. Needs no touched flags, so the scatter writes only gradients; 16 parameters per
/// step where the build has AVX-512. `half` as for adamTouched.
void adamNonzero(const AdamHyper& h, float* params, float* grads, AdamMoments& moments, std::int64_t begin,
                 std::int64_t end, std::uint16_t* half = nullptr);

}  // namespace demnerf::nerf
