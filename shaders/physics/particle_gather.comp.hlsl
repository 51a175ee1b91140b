// Per iteration, after the constraint families: every particle takes its neighbour delta (fluid
// density, particle contacts), then is pushed out of the rigid colliders of its env with Coulomb
// friction against the collider's motion over the substep.
#include "cressim/layout.h"
#include "cressim/particle.h"
#include "cressim/quat.h"
#include "cressim/rigid.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<ParticleObject> objects;
StructuredBuffer<uint4> phases;
StructuredBuffer<float4> deltas;
StructuredBuffer<float4> prev_positions;
StructuredBuffer<EnvRigidRange> env_rigid_ranges;
StructuredBuffer<ColliderModel> colliders;
StructuredBuffer<float4> body_positions;
StructuredBuffer<float4> body_rotations;
StructuredBuffer<float4> body_linear_velocities;
StructuredBuffer<float4> body_angular_velocities;
RWStructuredBuffer<float4> positions;

#include "particle_collide.hlsli"

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint i = id.x;
  if (i >= pc.particle_count) return;
  const uint4 ph = phases[i];
  float4 x = positions[i];
  if ((ph.w & PARTICLE_ACTIVE) == 0 || x.w <= 0) return;
  x.xyz += deltas[i].xyz;

  if (pc.has_rigid != 0) {
    const ParticleObject o = objects[ph.y];
    const float r = o.material.x, h = pc.gravity.w;
    const EnvRigidRange er = env_rigid_ranges[ph.z];
    const float3 x0 = prev_positions[i].xyz;
    for (uint c = er.bodies.z; c < er.bodies.z + er.bodies.w; ++c) {
      const ColliderModel cm = colliders[c];
      const ColliderPose s = collider_pose(cm);
      float3 n;
      float depth;
      if (!sphere_penetration(x.xyz, r, cm, s, n, depth)) continue;
      x.xyz += depth * n;
      // friction: the particle's slip against the collider surface over this substep
      const float3 surface_motion = h * (s.v + cross(s.w, x.xyz - s.body_p));
      const float3 slip = (x.xyz - x0) - surface_motion;
      const float3 tangential = slip - dot(slip, n) * n;
      const float t = length(tangential);
      const float mu = sqrt(o.material.y * cm.material.x);
      if (t > 1e-9) x.xyz -= tangential * (t <= mu * depth ? 1.0 : min(mu * depth / t, 1.0));
    }
  }
  positions[i] = x;
}
