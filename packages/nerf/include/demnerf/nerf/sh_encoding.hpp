#pragma once
// Real spherical-harmonics encoding of unit view directions (degree d gives d*d values).

namespace demnerf::nerf {

/// Writes degree*degree coefficients (degree 1..4) of the unit direction (x, y, z) to out.
void shEncode(int degree, float x, float y, float z, float* out);

}  // namespace demnerf::nerf
