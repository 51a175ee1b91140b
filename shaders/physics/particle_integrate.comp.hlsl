// Substep start: remember the positions, then move every active, finite-mass particle by its
// velocity after gravity, its external force (control.particle_forces) and its object's damping (an elastic body's solve starts nearer: below).
// Fluid within reach of its env's sink (control.fluid_sinks: a suction tip) flows into it at
// least as fast as a point sink of flow rate Q at a wall draws it: Q / (2 pi r^2) toward the
// point (half of the sphere around it is the wall), r no less than the sink's core radius (the
// tube's mouth, inside which the fluid is taken).
#include "cressim/layout.h"
#include "cressim/particle.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<ParticleObject> objects;
StructuredBuffer<uint4> phases;
RWStructuredBuffer<float4> positions;
RWStructuredBuffer<float4> velocities;
RWStructuredBuffer<float4> prev_positions;
StructuredBuffer<float> object_supports;
StructuredBuffer<float4> fluid_sinks;  // per env: (point xyz, reach w; 0: off), (flow rate Q m^3/s, core radius, -, -)
StructuredBuffer<float4> particle_forces;  // control.particle_forces: an external force (N, world) per particle

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint i = id.x;
  if (i >= pc.particle_count) return;
  const float4 x = positions[i];
  prev_positions[i] = x;
  const uint4 ph = phases[i];
  if ((ph.w & PARTICLE_ACTIVE) == 0 || x.w <= 0) return;
  const float h = pc.gravity.w, drag = 1 + h * objects[ph.y].material.z;
  float3 v = (velocities[i].xyz + h * (pc.gravity.xyz + x.w * particle_forces[i].xyz)) / drag;
  if (ph.x == PARTICLE_FLUID) {
    const float4 sink = fluid_sinks[2 * ph.z];
    const float3 d = sink.xyz - x.xyz;
    const float r = length(d);
    if (r < sink.w && r > 0) {
      const float3 n = d / r;
      const float2 flow = fluid_sinks[2 * ph.z + 1].xy;
      const float rc = max(r, flow.y);
      const float inflow = flow.x / (2 * 3.14159265 * rc * rc);
      v += max(inflow - dot(v, n), 0.0) * n;
    }
  }
  velocities[i].xyz = v;
  // An elastic body's solve (particle_tet.comp.hlsl) starts short of the inertial position by the
  // share of the substep's fall its last substep held back (particle_tet_support.comp.hlsl): a
  // body at rest starts at its static equilibrium, so a solve cut short keeps the static shape
  // exact whatever the iteration count; a falling one starts where it falls to.
  const float held = (ph.w & PARTICLE_ELASTIC) != 0 ? object_supports[ph.y] : 0;
  positions[i].xyz = x.xyz + h * v - held * h * h * pc.gravity.xyz / drag;
}
