// The compute rasterizer (CRESSIM_RASTER=compute): one workgroup per (camera, tile); tiles are
// 64x32 pixels, smaller (down to 16x16) where few small images would leave SMs idle.
// Visibility in two sweeps over the env's triangles into groupshared buffers: the nearest
// depth per pixel (atomic min of the float's bits, which order like the floats when positive),
// then the id of the triangle at that depth; then each pixel shades its triangle (ray through
// the pixel centre: exact depth and perspective-correct attributes) and writes the outputs
// straight into camera{g}.rgb/.depth/.segmentation. Small triangles are rasterised by the
// thread that set them up; large ones are queued and swept by the whole group, so one
// screen-filling triangle does not leave the other threads idle.
// Why: every SM runs it, where graphics pipelines on compute-first GPUs (H100) get only a few
// graphics units.
#include "cressim/quat.h"
#include "cressim/render.h"

#include "raster_resources.hlsli"
#include "shading.hlsli"
#include "frustum.hlsli"

[[vk::binding(15)]] StructuredBuffer<uint2> env_renderables;  // per env: first renderable, count
[[vk::binding(16)]] StructuredBuffer<uint4> mesh_ranges;      // per mesh: first index, index count, vertex offset,
                                                              // bounding radius (float bits)
[[vk::binding(17)]] StructuredBuffer<uint> mesh_indices;
[[vk::binding(18)]] StructuredBuffer<uint> group_cameras;     // this group's camera per layer
[[vk::binding(19)]] RWStructuredBuffer<uint> out_rgb;         // (layers, H, W) RGBA8
[[vk::binding(20)]] RWStructuredBuffer<float> out_depth;
[[vk::binding(21)]] RWStructuredBuffer<uint> out_segmentation;

struct Params {
  uint width;
  uint height;
  uint products;  // CameraProduct bits: the outputs this group writes (others are bound to a stand-in)
  uint tile_shift_x;  // a tile is 1 << tile_shift_x by 1 << tile_shift_y pixels (<= MAX_TILE): shifts,
  uint tile_shift_y;  // not divisions, in the per-pixel index arithmetic
};
[[vk::push_constant]] ConstantBuffer<Params> pc;

static const uint MAX_TILE = 64 * 32, THREADS = 256;
static const uint BIG_AREA = 48;   // bounding boxes larger than this (pixels) are swept by the group
static const uint MAX_BIG = 256;
static const uint NONE = 0xffffffffu;

groupshared uint zbuf[MAX_TILE];
groupshared uint idbuf[MAX_TILE];
groupshared uint big[MAX_BIG];
groupshared uint big_count;

int2 tile_size() {
  return int2(1 << pc.tile_shift_x, 1 << pc.tile_shift_y);
}

uint tile_pixels() {
  return 1u << (pc.tile_shift_x + pc.tile_shift_y);
}

struct Screen {       // a triangle in pixels, clipped at the near plane into at most two
  float3 p[4];        // x, y in pixels, z = 1 / depth
  uint n;             // polygon vertices (0: culled, 3 or 4)
  int4 box;           // pixel bounds within the tile (x0, y0, x1, y1), inclusive-exclusive
};

float3 vertex_local(RenderableData r, uint vertex, float4 eye_q, float3 eye_p) {
  return quat_unrotate(eye_q, world_position(r, vertex) - eye_p);
}

float3 to_screen(CameraData c, float3 v) {
  return float3(c.intrinsics.xy * v.xy / v.z + c.intrinsics.zw, 1.0 / v.z);
}

Screen setup(CameraData c, float3 v[3], int2 origin) {
  Screen s;
  s.n = 0;
  const float near = c.clip.x;
  // Sutherland-Hodgman against z = near
  uint n = 0;
  float3 poly[4];
  for (uint i = 0; i < 3; ++i) {
    const float3 a = v[i], b = v[(i + 1) % 3];
    const bool ia = a.z >= near, ib = b.z >= near;
    if (ia) poly[n++] = a;
    if (ia != ib && n < 4) poly[n++] = lerp(a, b, (near - a.z) / (b.z - a.z));
  }
  if (n < 3) return s;
  float2 lo = float2(1e30, 1e30), hi = float2(-1e30, -1e30);
  for (uint k = 0; k < n; ++k) {
    s.p[k] = to_screen(c, poly[k]);
    lo = min(lo, s.p[k].xy);
    hi = max(hi, s.p[k].xy);
  }
  // pixels whose centres (x + 0.5) can be inside
  const int2 tile_hi = min(origin + tile_size(), int2(pc.width, pc.height));
  s.box = int4(max(int2(ceil(lo - 0.5)), origin), min(int2(floor(hi - 0.5)) + 1, tile_hi));
  if (any(s.box.xy >= s.box.zw)) return s;
  s.n = n;
  return s;
}

// false when the renderable's bounding sphere misses the tile's frustum (then none of its
// triangles can cover a pixel of the tile); the culling pass's test, on the tile
bool may_cover(RenderableData r, uint4 m, CameraData c, float4 eye_q, float3 eye_p, int2 origin) {
  // vertices from a buffer or particles: the mesh's radius does not bound them
  if ((r.maps.y & RENDER_FLAT_NORMALS) != 0 || (r.maps.w & RENDER_WORLD_VERTICES) != 0) return true;
  const float3 centre = quat_unrotate(eye_q, positions[r.ids.x].xyz - eye_p);
  const int2 hi = min(origin + tile_size(), int2(pc.width, pc.height));
  return sphere_in_view(c, centre, bounding_radius(asfloat(m.w), scales[r.ids.x].xyz), float2(origin), float2(hi));
}

// the edge function, exactly antisymmetric in a and b: the two triangles sharing an edge get
// opposite values at a pixel centre, rounding (and fused multiply-adds) included, so a centre
// on the edge cannot be missed by both (the NVIDIA compiler left such holes along diagonals)
float edge(float2 a, float2 b, float2 p) {
  const bool swap = a.x > b.x || (a.x == b.x && a.y > b.y);
  const float2 lo = swap ? b : a, hi = swap ? a : b;
  const float e = (hi.x - lo.x) * (p.y - lo.y) - (hi.y - lo.y) * (p.x - lo.x);
  return swap ? -e : e;
}

// where the ray from the eye along d meets the plane of the triangle v0, v0 + e1, v0 + e2
// (Moller-Trumbore; outside the triangle too): barycentrics b1, b2, the ray parameter (depth,
// as d.z = 1) and the determinant (0: the ray runs along the plane; then the rest is not finite)
float4 ray_plane(float3 d, float3 v0, float3 e1, float3 e2) {
  const float3 h = cross(d, e2), q = cross(-v0, e1);
  const float det = dot(e1, h);
  return float4(float3(dot(-v0, h), dot(d, q), dot(e2, q)) / det, det);
}

// one pixel against the (fan of the) polygon; mode 0: depth, 1: id
void cover(Screen s, int2 px, int2 origin, uint mode, uint id, float near, float far) {
  const float2 p = float2(px) + 0.5;
  for (uint t = 0; t + 2 < s.n; ++t) {
    const float3 a = s.p[0], b = s.p[t + 1], c = s.p[t + 2];
    const float area = edge(a.xy, b.xy, c.xy);
    if (abs(area) < 1e-12) continue;
    const float w0 = edge(b.xy, c.xy, p) / area, w1 = edge(c.xy, a.xy, p) / area, w2 = edge(a.xy, b.xy, p) / area;
    if (w0 < 0 || w1 < 0 || w2 < 0) continue;
    const float z = 1.0 / (w0 * a.z + w1 * b.z + w2 * c.z);
    if (z < near || z > far) continue;
    const uint local = (uint(px.y - origin.y) << pc.tile_shift_x) + uint(px.x - origin.x);
    if (mode == 0) {
      uint previous;
      InterlockedMin(zbuf[local], asuint(z), previous);
    } else if (zbuf[local] == asuint(z)) {
      idbuf[local] = id;
    }
    return;
  }
}

[numthreads(THREADS, 1, 1)]
void main(uint3 group : SV_GroupID, uint tid : SV_GroupIndex) {
  const uint layer = group.y, camera = group_cameras[layer];
  const CameraData c = cameras[camera];
  const uint tiles_x = (pc.width + (1u << pc.tile_shift_x) - 1) >> pc.tile_shift_x;
  const int2 origin = int2(group.x % tiles_x, group.x / tiles_x) * tile_size();
  const uint eye_row = c.ids.x;
  const float4 eye_q = rotations[eye_row];
  const float3 eye_p = positions[eye_row].xyz;
  const uint2 list = env_renderables[c.ids.y];
  const float near = c.clip.x, far = c.clip.y;

  for (uint i = tid; i < tile_pixels(); i += THREADS) {
    zbuf[i] = NONE;
    idbuf[i] = NONE;
  }
  if (tid == 0) big_count = 0;
  GroupMemoryBarrierWithGroupSync();

  for (uint mode = 0; mode < 2; ++mode) {
    // each thread sets up triangles; small ones it rasterises, large ones go to the queue
    for (uint k = 0; k < list.y; ++k) {
      const RenderableData r = renderables[list.x + k];
      const uint4 m = mesh_ranges[r.ids.y];
      if (!may_cover(r, m, c, eye_q, eye_p, origin)) continue;
      for (uint t = tid; t < m.y / 3; t += THREADS) {
        float3 v[3];
        for (uint j = 0; j < 3; ++j) v[j] = vertex_local(r, mesh_indices[m.x + 3 * t + j] + m.z + r.maps.z, eye_q, eye_p);
        const Screen s = setup(c, v, origin);
        if (s.n == 0) continue;
        const uint id = (k << 20) | t;
        const int2 size = s.box.zw - s.box.xy;
        if (uint(size.x * size.y) > BIG_AREA) {
          if (mode == 0) {
            uint slot;
            InterlockedAdd(big_count, 1, slot);
            if (slot < MAX_BIG) {
              big[slot] = id;
              continue;
            }
          } else if (big_count <= MAX_BIG) {
            continue;  // queued in the depth sweep: the group sweeps it below
          }
        }
        for (int y = s.box.y; y < s.box.w; ++y)
          for (int x = s.box.x; x < s.box.z; ++x) cover(s, int2(x, y), origin, mode, id, near, far);
      }
    }
    GroupMemoryBarrierWithGroupSync();
    // the queue, each triangle swept by every thread
    const uint queued = min(big_count, MAX_BIG);
    for (uint b = 0; b < queued; ++b) {
      const uint id = big[b], k = id >> 20, t = id & 0xfffffu;
      const RenderableData r = renderables[list.x + k];
      const uint4 m = mesh_ranges[r.ids.y];
      float3 v[3];
      for (uint j = 0; j < 3; ++j) v[j] = vertex_local(r, mesh_indices[m.x + 3 * t + j] + m.z + r.maps.z, eye_q, eye_p);
      const Screen s = setup(c, v, origin);
      const int2 size = s.box.zw - s.box.xy;
      for (uint q = tid; q < uint(size.x * size.y); q += THREADS)
        cover(s, s.box.xy + int2(q % uint(size.x), q / uint(size.x)), origin, mode, id, near, far);
    }
    GroupMemoryBarrierWithGroupSync();
  }

  // shading: the ray through each pixel centre meets its triangle (Moller-Trumbore)
  for (uint i = tid; i < tile_pixels(); i += THREADS) {
    const int2 px = origin + int2(i & ((1u << pc.tile_shift_x) - 1), i >> pc.tile_shift_x);
    if (px.x >= int(pc.width) || px.y >= int(pc.height)) continue;
    const uint at = (layer * pc.height + uint(px.y)) * pc.width + uint(px.x);
    const uint id = idbuf[i];
    if (id == NONE) {
      if (pc.products & 1) out_rgb[at] = 0xff000000u;  // opaque black
      if (pc.products & 2) out_depth[at] = 0;
      if (pc.products & 4) out_segmentation[at] = 0;
      continue;
    }
    const uint k = id >> 20, t = id & 0xfffffu;
    const RenderableData r = renderables[list.x + k];
    const uint4 m = mesh_ranges[r.ids.y];
    uint vi[3];
    float3 v[3];
    for (uint j = 0; j < 3; ++j) {
      vi[j] = mesh_indices[m.x + 3 * t + j] + m.z + r.maps.z;
      v[j] = vertex_local(r, vi[j], eye_q, eye_p);
    }
    const float3 d = float3((float2(px) + 0.5 - c.intrinsics.zw) / c.intrinsics.xy, 1);  // z = 1: t is depth
    const float3 e1 = v[1] - v[0], e2 = v[2] - v[0];
    const float4 hit = ray_plane(d, v[0], e1, e2);
    const float raster_depth = asfloat(zbuf[i]);
    // a sliver (where many triangles meet, such as a sphere's pole) can win the id pass with
    // an ill-conditioned ray hit: keep the rasterised depth and flat attributes there
    const bool exact = abs(hit.w) > 1e-20 && abs(hit.z - raster_depth) <= 1e-3 * raster_depth;
    const float b1 = exact ? hit.x : 1.0 / 3, b2 = exact ? hit.y : 1.0 / 3, depth = exact ? hit.z : raster_depth;
    const float b0 = 1 - b1 - b2;
    const float2 uv0 = vertex_uvs[vi[0]], uv1 = vertex_uvs[vi[1]] - uv0, uv2 = vertex_uvs[vi[2]] - uv0;
    SurfacePoint p;
    p.world = eye_p + quat_rotate(eye_q, d * depth);
    p.normal = (r.maps.y & RENDER_FLAT_NORMALS) != 0
                   ? quat_rotate(eye_q, cross(e1, e2))  // flat: the triangle's
                   : b0 * world_normal(r, vi[0]) + b1 * world_normal(r, vi[1]) + b2 * world_normal(r, vi[2]);
    p.uv = uv0 + b1 * uv1 + b2 * uv2;
    p.burn = b0 * world_burn(r, vi[0]) + b1 * world_burn(r, vi[1]) + b2 * world_burn(r, vi[2]);
    // the change per pixel: the same plane hit by the rays one pixel over
    p.uv_grad = 0;
    p.dp_dx = p.dp_dy = 0;
    if (exact) {
      const float2 bx = ray_plane(d + float3(1 / c.intrinsics.x, 0, 0), v[0], e1, e2).xy - hit.xy;
      const float2 by = ray_plane(d + float3(0, 1 / c.intrinsics.y, 0), v[0], e1, e2).xy - hit.xy;
      p.uv_grad = float4(bx.x * uv1 + bx.y * uv2, by.x * uv1 + by.y * uv2);
      p.dp_dx = quat_rotate(eye_q, bx.x * e1 + bx.y * e2);
      p.dp_dy = quat_rotate(eye_q, by.x * e1 + by.y * e2);
    }
    if (pc.products & 1) {
      const uint4 bytes = uint4(round(saturate(encode_color(shade(r, p, eye_p))) * 255));
      out_rgb[at] = bytes.x | (bytes.y << 8) | (bytes.z << 16) | (bytes.w << 24);
    }
    if (pc.products & 2) out_depth[at] = depth;
    if (pc.products & 4) out_segmentation[at] = r.ids.z;
  }
}
