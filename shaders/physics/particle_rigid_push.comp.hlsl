// After each gather, one thread per env: the dynamic bodies take their share of this
// iteration's particle contacts (particle_gather) as the particles do, over the substep: a
// position and rotation change and the velocity change that goes with it (dx / h), kept for the
// rest of the frame (the rigid solver has already stepped the body to the frame's end, and the
// particle passes place it back along its velocity). A body's contacts add up: each was split
// with the body's mass shared among the particles that pushed it last (body_contact_counts), so
// N equal contacts move it as one joint solve would; split as if each were the only one, a box
// on a soft cube was thrown off, and averaged it sank through. Taken over the frame instead of
// the substep, a body got 1/substeps of the momentum its particles lost, so particles under it
// bore substeps times its weight.
#include "cressim/layout.h"
#include "cressim/particle.h"
#include "cressim/quat.h"
#include "cressim/rigid.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<ParticleEnvRange> env_ranges;
StructuredBuffer<EnvRigidRange> env_rigid_ranges;
StructuredBuffer<BodyModel> bodies;
StructuredBuffer<float4> rigid_pushes;
StructuredBuffer<float4> rigid_contacts;
StructuredBuffer<float4> positions;
StructuredBuffer<float4> prev_positions;
RWStructuredBuffer<float4> body_positions;
RWStructuredBuffer<float4> body_rotations;
RWStructuredBuffer<float4> body_linear_velocities;
RWStructuredBuffer<float4> body_angular_velocities;
RWStructuredBuffer<uint> body_contact_counts;  // particles that pushed the body, for the next gather

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint env = id.x;
  if (env >= pc.env_count || pc.has_rigid == 0) return;
  const uint4 pr = env_ranges[env].range;
  const uint4 br = env_rigid_ranges[env].bodies;
  const float h = pc.gravity.w, frame_left = h * pc.grid.w * (1 - pc.grid.y);
  for (uint b = br.x; b < br.x + br.y; ++b) {
    const BodyModel m = bodies[b];
    if (m.inv_inertia.w <= 0) continue;
    float3 p = float3(0, 0, 0), l = float3(0, 0, 0), particle_motion = float3(0, 0, 0);
    uint count = 0;
    for (uint i = pr.x; i < pr.x + pr.y; ++i) {
      const float4 push = rigid_pushes[i];
      if (uint(push.w) != b + 1) continue;
      p += push.xyz;
      l += cross(rigid_contacts[i].xyz - body_positions[b].xyz, push.xyz);
      particle_motion += positions[i].xyz - prev_positions[i].xyz;
      ++count;
    }
    if (count > 0) body_contact_counts[b] = count;
    if (dot(p, p) == 0) continue;
    const float4 q = body_rotations[b];
    const float3 dx = -m.inv_inertia.w * p;
    const float3 dw = -quat_rotate(q, m.inv_inertia.xyz * quat_unrotate(q, l));
    // The velocity change, as a contact's velocity pass would leave it: the body leaves along the
    // push no faster than the particles that pushed it move (or than it already did), so an
    // overlap resolved in one substep (bodies authored into particles) does not launch it.
    const float3 v = body_linear_velocities[b].xyz, along = normalize(dx);
    const float gain = dot(dx, along) / h;
    const float room = max(dot(particle_motion / (count * h), along), dot(v, along)) - dot(v, along);
    const float k = gain > 0 ? saturate(room / gain) : 1;
    body_positions[b].xyz += dx + k * dx / h * frame_left;
    body_rotations[b] = quat_add_rotation(q, dw);
    body_linear_velocities[b].xyz = v + k * dx / h;
    body_angular_velocities[b].xyz += k * dw / h;
  }
}
