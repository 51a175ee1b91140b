// Writes the vertices the rasterizer draws for particle objects straight from the physics
// buffers, one thread per generated vertex: a soft-body surface vertex is its particle with the
// area-weighted normal of the surface triangles around it (a gather: no atomics, the same sum
// in the same order every frame); a strand tube vertex is its particle moved by the strand
// radius along a ring direction of the averaged frames of the segments beside it; a tube's end
// cap centre is its end particle, facing out along the end segment.
#include "cressim/particle.h"
#include "cressim/quat.h"
#include "cressim/render.h"

[[vk::binding(0)]] StructuredBuffer<float4> particle_positions;  // particles.positions
[[vk::binding(1)]] StructuredBuffer<uint4> particle_phases;
[[vk::binding(2)]] StructuredBuffer<ParticleObject> particle_objects;
[[vk::binding(3)]] StructuredBuffer<float4> particle_orientations;  // strand segment frames
[[vk::binding(4)]] StructuredBuffer<uint4> recipes;                 // render.particle_vertices
[[vk::binding(5)]] StructuredBuffer<uint> adjacency;
[[vk::binding(6)]] StructuredBuffer<uint4> triangles;
[[vk::binding(7)]] RWStructuredBuffer<float4> vertex_positions;
[[vk::binding(8)]] RWStructuredBuffer<float4> vertex_normals;  // w: the share coagulated (shading.hlsli)
[[vk::binding(9)]] StructuredBuffer<float> particle_damage;     // particles.damage (heat)

struct Params {
  uint count;  // generated vertices
  uint base;   // the first one's index in vertex_positions
};
[[vk::push_constant]] ConstantBuffer<Params> pc;

static const float TWO_PI = 6.28318531;

[numthreads(64, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint i = id.x;
  if (i >= pc.count) return;
  const uint4 r = recipes[i];
  const uint kind = r.x & 0xf, particle = r.y;
  float3 p = particle_positions[particle].xyz, n = float3(0, 0, 1);
  if (kind == PARTICLE_VERTEX_SURFACE) {
    float3 sum = 0;
    for (uint k = r.z; k < r.z + r.w; ++k) {
      const uint4 t = triangles[adjacency[k]];
      const float3 a = particle_positions[t.x].xyz;
      sum += cross(particle_positions[t.y].xyz - a, particle_positions[t.z].xyz - a);  // |.| = 2 x area
    }
    const float len = length(sum);
    n = len > 0 ? sum / len : n;
  } else if (kind == PARTICLE_VERTEX_TUBE) {
    float4 qa = particle_orientations[r.z], qb = particle_orientations[r.w];
    if (dot(qa, qb) < 0) qb = -qb;  // the same rotation, the nearer sign
    const float4 q = normalize(qa + qb);
    const float angle = TWO_PI * float((r.x >> 4) & 0xff) / float((r.x >> 12) & 0xff);
    n = quat_rotate(q, float3(cos(angle), sin(angle), 0));
    p += particle_objects[particle_phases[particle].y].material.x * n;
  } else if (kind == PARTICLE_VERTEX_CAP) {
    n = quat_rotate(particle_orientations[r.z], float3(0, 0, r.w != 0 ? 1 : -1));  // frame z: along the strand
  } else {
    return;  // fluid particles: drawn in screen space (fluid_*.comp.hlsl)
  }
  // the share of proteins denatured, 1 - exp(-Omega), of a body with heat
  const bool heat = particle_objects[particle_phases[particle].y].heat.x > 0;
  const float burn = heat ? 1 - exp(-particle_damage[particle]) : 0;
  vertex_positions[pc.base + i] = float4(p, 1);
  vertex_normals[pc.base + i] = float4(n, burn);
}
