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
#include "particle_gather.hlsli"

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint i = id.x;
  if (i >= pc.particle_count) return;
  const uint4 ph = phases[i];
  float4 x = positions[i];
  if ((ph.w & PARTICLE_ACTIVE) == 0 || x.w <= 0) return;
  x.xyz += deltas[i].xyz;

  if (pc.has_rigid != 0) x = collide_near_colliders(i, ph, x);
  positions[i] = x;
}
