#pragma once
// mip-NeRF 360's distortion loss of one ray (Barron et al. 2022, eq. 15), for train.distortion:
//   L = sum_{i,j} w_i w_j |s_i - s_j| + 1/3 sum_i w_i^2 ds_i
// over the ray's samples (weight w = transmittance x alpha, midpoint s, length ds). It is small
// when the ray's weight sits in one short stretch and large when it is spread along the ray, so
// it sharpens the density edge that the colour loss alone leaves soft (the colour does not care
// where along the ray a pixel's weight sits). Distances are in units of `unit` (the trainer
// passes the scene box's diagonal) and measured from the ray's first sample: the loss does not
// depend on the origin, and small offsets keep the float differences below exact.
//
// The trainer composites front to back and knows the ray's totals only at its end, so, as for
// the colour (colorSigmaGradient), each sample records prefix sums up to and with itself and the
// backward assembles d(L)/d(sigma_i) from them and the totals. With g_k = dL/dw_k,
//   g_k = 2 (s_k (2 W_<k - W) + M - 2 M_<k) + 2/3 w_k ds_k
// (W, M: the sums of w and w s; _<k over the samples in front of k), and since w_k depends on
// sigma_i as dt_i (T_{i+1} [k = i] - w_k [k > i]),
//   dL/dsigma_i = dt_i (g_i T_{i+1} - sum_{k>i} w_k g_k).
// g_k is linear in the totals: g_k = a_k - 2 s_k W + 2 M with a_k = 4 (s_k W_<k - M_<k) +
// 2/3 w_k ds_k, so sum_{k<=i} w_k g_k = A_<=i - 2 W M_<=i + 2 M W_<=i (A: the sum of w a), and
// over the whole ray it is A = 2 L (L is quadratic in w).

namespace demnerf::nerf {

/// Running sums of one ray's distortion terms, front to back (one per ray, like RayAccum).
struct DistortionAccum {
  float w = 0.0f, ws = 0.0f, wa = 0.0f;  ///< sums of w, w s and w a over the samples added
  float origin = 0.0f;                   ///< t of the first sample (s = (t - origin) / unit)
  bool started = false;

  /// Adds the sample behind those added so far (weight w, midpoint t, length dt, as RayAccum);
  /// writes the sums up to and with it and its s to upto[4] for distortionSigmaGradient.
  void add(float w_i, float t, float dt, float inv_unit, float* upto) {
    if (!started) origin = t, started = true;
    const float s = (t - origin) * inv_unit, ds = dt * inv_unit;
    const float a = 4.0f * (s * w - ws) + (2.0f / 3.0f) * w_i * ds;
    wa += w_i * a;
    w += w_i;
    ws += w_i * s;
    upto[0] = w, upto[1] = ws, upto[2] = wa, upto[3] = s;
  }
  /// The ray's distortion L (in `unit`s).
  float loss() const { return 0.5f * wa; }
};

/// d(L)/d(sigma_i) / dt_i of sample i: `total` is the ray's accumulator after its last sample,
/// upto[4] what its add() wrote, w_i its weight, dt its length, t_next the transmittance behind it.
inline float distortionSigmaGradient(const DistortionAccum& total, const float* upto, float w_i, float dt,
                                     float t_next, float inv_unit) {
  const float s = upto[3], ds = dt * inv_unit;
  const float w_before = upto[0] - w_i, ws_before = upto[1] - w_i * s;
  const float g = 2.0f * (s * (2.0f * w_before - total.w) + total.ws - 2.0f * ws_before) + (2.0f / 3.0f) * w_i * ds;
  const float upto_wg = upto[2] - 2.0f * total.w * upto[1] + 2.0f * total.ws * upto[0];
  return g * t_next - (total.wa - upto_wg);
}

}  // namespace demnerf::nerf
