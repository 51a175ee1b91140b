// Rigid-particle attachments, after each gather: an attached particle is placed at its body
// point (rigidly, or part of the way for a compliant one); a pending slot first takes the local
// offset from the current poses. A slot that holds a strand frame also turns that segment's
// material frame to the body's rotation times the held offset (the same share rule on the
// frame's inverse inertia), so a turning tool twists the thread. Slots are created and
// released by writing control.particle_attachments, so no buffer changes size. (The elastic
// solve leaves a rigidly held particle where it is and reports its load on the body:
// particle_tet.comp.hlsl.)
#include "cressim/layout.h"
#include "cressim/particle.h"
#include "cressim/quat.h"
#include "cressim/rigid.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<float4> body_positions;
StructuredBuffer<float4> body_rotations;
StructuredBuffer<float4> body_linear_velocities;
StructuredBuffer<float4> body_angular_velocities;
RWStructuredBuffer<ParticleAttachment> attachments;
RWStructuredBuffer<float4> positions;
RWStructuredBuffer<float4> orientations;
StructuredBuffer<float> orientation_weights;

#include "particle_attach.hlsli"

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  if (id.x < pc.attachment_count) apply_attachment(id.x);
}
