// Per iteration, after the constraint families: every particle takes its neighbour delta (fluid
// density, particle contacts), then is pushed out of the rigid colliders of its env near it this
// substep (particle_collider_near) with Coulomb friction against the collider's motion over the
// substep. Against a dynamic body the overlap is shared by inverse mass (the body's at the
// contact point, its mass split among the particles that last pushed it:
// particle_rigid_push.comp.hlsl); the body's share is left in rigid_pushes for
// particle_rigid_push (two-way coupling). The force on any body is summed per particle over the
// frame in rigid_forces (particle_rigid_forces adds them up per body).
#include "cressim/layout.h"
#include "cressim/particle.h"
#include "cressim/quat.h"
#include "cressim/rigid.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<ParticleObject> objects;
StructuredBuffer<uint4> phases;
StructuredBuffer<float4> deltas;
StructuredBuffer<float4> prev_positions;
StructuredBuffer<BodyModel> bodies;
StructuredBuffer<uint> body_contact_counts;  // particle_rigid_push: particles sharing a body's mass
StructuredBuffer<uint> collider_near;
RWStructuredBuffer<float4> positions;
RWStructuredBuffer<float4> rigid_pushes;   // xyz impulse-like correction on the body, w body + 1 (0: none)
RWStructuredBuffer<float4> rigid_contacts; // xyz contact point
RWStructuredBuffer<float4> rigid_forces;   // xyz N on the body, frame average so far; w body + 1 (0: none)

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
    const float3 x0 = prev_positions[i].xyz;
    rigid_pushes[i] = float4(0, 0, 0, 0);
    FOR_EACH_NEAR_COLLIDER(i, ph.z, cm, {
      const ColliderPose s = collider_pose(cm);
      float3 n;
      float depth;
      if (!sphere_penetration(x.xyz, r, cm, s, n, depth)) continue;
      const uint b = cm.ids.x;
      float share = 1, wb = 0;
      if (b != CRESSIM_NONE && bodies[b].inv_inertia.w > 0) {
        // the body's generalized inverse mass at the contact point, along n
        const float4 q = body_rotations[b];
        const float3 arm = x.xyz - r * n - s.body_p, rn = quat_unrotate(q, cross(arm, n));
        wb = (bodies[b].inv_inertia.w + dot(rn, bodies[b].inv_inertia.xyz * rn)) * max(body_contact_counts[b], 1u);
        share = x.w / (x.w + wb);
      }
      if (b != CRESSIM_NONE) rigid_contacts[i] = float4(x.xyz - r * n, 0);
      // friction: the particle's slip against the collider surface over this substep
      const float3 slip = (x.xyz + depth * n - x0) - surface_motion(s, x.xyz, h);
      const float3 tangential = slip - dot(slip, n) * n;
      const float t = length(tangential);
      const float mu = contact_friction(o.material.y, cm);
      const float3 correction = depth * n - (t > 1e-9 ? tangential * (t <= mu * depth ? 1.0 : min(mu * depth / t, 1.0)) : 0);
      x.xyz += share * correction;
      if (wb > 0) rigid_pushes[i] = float4(correction / (x.w + wb), float(b + 1));
      if (b != CRESSIM_NONE && x.w > 0) {
        // the momentum the particle loses and the body gains: the particle moves by share x
        // correction over the substep (m share correction / h = correction / ((w + wb) h)); a
        // dynamic body takes the opposite (particle_rigid_push), a kinematic one (wb 0) none
        const float3 momentum = correction / ((x.w + wb) * h);
        rigid_forces[i] = float4(rigid_forces[i].xyz - momentum / (h * pc.grid.w), float(b + 1));
      }
    })
  }
  positions[i] = x;
}
