// Image-based lighting, step 1 of 3: each slot's map box-filtered onto the IBL_GRID_W x
// IBL_GRID_H equirectangular grid (linear radiance x the slot's scale), so the next steps
// read a small map that no bright texel slips through. One thread per grid cell.
#include "cressim/render.h"

[[vk::binding(0)]] StructuredBuffer<TextureInfo> texture_infos;
[[vk::binding(1)]] StructuredBuffer<uint> texels;
[[vk::binding(2)]] StructuredBuffer<float4> ibl_slots;  // x texture index (float), yzw scale rgb
[[vk::binding(3)]] RWStructuredBuffer<float4> ibl_grid;

#include "environment_map.hlsli"

[numthreads(64, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint cell = id.x, slot = id.y;
  if (cell >= IBL_GRID_W * IBL_GRID_H) return;
  const float4 s = ibl_slots[slot];
  const TextureInfo t = texture_infos[uint(s.x)];
  const uint2 c = uint2(cell % IBL_GRID_W, cell / IBL_GRID_W);
  // the texels whose centres fall in the cell (at least the nearest one)
  const float2 size = float2(t.extent.yz), grid = float2(IBL_GRID_W, IBL_GRID_H);
  const int2 lo = int2(ceil(float2(c) * size / grid - 0.5)), hi = int2(ceil(float2(c + 1) * size / grid - 0.5));
  float3 sum = 0;
  uint n = 0;
  for (int y = lo.y; y < max(hi.y, lo.y + 1); ++y)
    for (int x = lo.x; x < max(hi.x, lo.x + 1); ++x) {
      sum += map_texel(t, int2(x, y));
      ++n;
    }
  ibl_grid[slot * IBL_GRID_W * IBL_GRID_H + cell] = float4(sum / n * s.yzw, 0);
}
