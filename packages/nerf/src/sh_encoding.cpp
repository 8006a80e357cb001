#include "demnerf/nerf/sh_encoding.hpp"

namespace demnerf::nerf {

void shEncode(int degree, float x, float y, float z, float* out) {
  out[0] = 0.28209479177387814f;
  if (degree <= 1) return;
  out[1] = -0.48860251190291987f * y;
  out[2] = 0.48860251190291987f * z;
  out[3] = -0.48860251190291987f * x;
  if (degree <= 2) return;
  const float xx = x * x, yy = y * y, zz = z * z;
  out[4] = 1.0925484305920792f * x * y;
  out[5] = -1.0925484305920792f * y * z;
  out[6] = 0.94617469575755997f * zz - 0.31539156525251999f;
  out[7] = -1.0925484305920792f * x * z;
  out[8] = 0.54627421529603959f * (xx - yy);
  if (degree <= 3) return;
  out[9] = 0.59004358992664352f * y * (-3.0f * xx + yy);
  out[10] = 2.8906114426405538f * x * y * z;
  out[11] = 0.45704579946446572f * y * (1.0f - 5.0f * zz);
  out[12] = 0.3731763325901154f * z * (5.0f * zz - 3.0f);
  out[13] = 0.45704579946446572f * x * (1.0f - 5.0f * zz);
  out[14] = 1.4453057213202769f * z * (xx - yy);
  out[15] = 0.59004358992664352f * x * (-xx + 3.0f * yy);
}

}  // namespace demnerf::nerf
