// Equirectangular maps (rows from +z at the top to -z, columns from azimuth -pi to pi, +x in
// the middle; world-frame directions) and the SH9 basis, for image-based lighting.
#include "cressim/ibl.h"

static const float IBL_PI = 3.14159265;

float2 equirect_uv(float3 d) {  // [0, 1)^2
  return float2(0.5 + atan2(d.y, d.x) / (2 * IBL_PI), acos(clamp(d.z, -1.0, 1.0)) / IBL_PI);
}

float3 equirect_direction(float2 uv) {
  const float phi = (uv.x - 0.5) * 2 * IBL_PI, theta = uv.y * IBL_PI;
  return float3(sin(theta) * cos(phi), sin(theta) * sin(phi), cos(theta));
}

// the nine real spherical harmonics of order <= 2 at a unit direction
void sh9_basis(float3 d, out float y[9]) {
  y[0] = 0.282095;
  y[1] = 0.488603 * d.y;
  y[2] = 0.488603 * d.z;
  y[3] = 0.488603 * d.x;
  y[4] = 1.092548 * d.x * d.y;
  y[5] = 1.092548 * d.y * d.z;
  y[6] = 0.315392 * (3 * d.z * d.z - 1);
  y[7] = 1.092548 * d.x * d.z;
  y[8] = 0.546274 * (d.x * d.x - d.y * d.y);
}
