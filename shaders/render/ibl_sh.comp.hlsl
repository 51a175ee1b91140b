// Image-based lighting, step 2: the irradiance of each slot's grid as nine SH coefficients
// (Ramamoorthi and Hanrahan 2001), stored as the diffuse radiance of a white Lambertian surface:
// L_lm x A_l / pi (A = pi, 2 pi / 3, pi / 4), so shading sums coefficient x Y_lm(n).
// One group per slot: each thread sums its cells (weighted by solid angle), then the group adds.
#include "cressim/render.h"

[[vk::binding(0)]] StructuredBuffer<float4> ibl_grid;
[[vk::binding(1)]] RWStructuredBuffer<float4> ibl_sh;

#include "ibl_math.hlsli"

static const uint THREADS = 256;
groupshared float3 partial[THREADS];

[numthreads(THREADS, 1, 1)]
void main(uint3 group : SV_GroupID, uint tid : SV_GroupIndex) {
  const uint slot = group.x, cells = IBL_GRID_W * IBL_GRID_H;
  float3 acc[9];
  for (uint k = 0; k < 9; ++k) acc[k] = 0;
  const float d_theta = IBL_PI / IBL_GRID_H, d_phi = 2 * IBL_PI / IBL_GRID_W;
  for (uint i = tid; i < cells; i += THREADS) {
    const float2 uv = (float2(i % IBL_GRID_W, i / IBL_GRID_W) + 0.5) / float2(IBL_GRID_W, IBL_GRID_H);
    const float3 d = equirect_direction(uv);
    const float theta = uv.y * IBL_PI;
    const float3 radiance = ibl_grid[slot * cells + i].rgb * sin(theta) * d_theta * d_phi;
    float y[9];
    sh9_basis(d, y);
    for (uint k = 0; k < 9; ++k) acc[k] += radiance * y[k];
  }
  const float band[9] = {1.0, 2.0 / 3, 2.0 / 3, 2.0 / 3, 0.25, 0.25, 0.25, 0.25, 0.25};  // A_l / pi
  for (uint k = 0; k < 9; ++k) {
    partial[tid] = acc[k];
    GroupMemoryBarrierWithGroupSync();
    for (uint stride = THREADS / 2; stride > 0; stride /= 2) {
      if (tid < stride) partial[tid] += partial[tid + stride];
      GroupMemoryBarrierWithGroupSync();
    }
    if (tid == 0) ibl_sh[slot * IBL_SH + k] = float4(partial[0] * band[k], 0);
    GroupMemoryBarrierWithGroupSync();
  }
}
