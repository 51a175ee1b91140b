// What both one-workgroup iteration kernels (particle_iterations, particle_fluid_iterations)
// bind and hold: the particles, the colliders and attachment slots, and the env's particles in
// group memory, which the neighbour, gather and attachment headers read through
// NEIGHBOR_POSITION and ATTACHED_POSITION. Each kernel declares what only it reads after this.
#include "cressim/layout.h"
#include "cressim/particle.h"
#include "cressim/quat.h"
#include "cressim/rigid.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<ParticleEnvRange> env_ranges;
StructuredBuffer<ParticleObject> objects;
StructuredBuffer<uint4> phases;
StructuredBuffer<float4> prev_positions;
StructuredBuffer<BodyModel> bodies;
StructuredBuffer<uint> body_contact_counts;
RWStructuredBuffer<uint> collider_near;  // this substep's marks, set here
RWStructuredBuffer<float4> velocities;  // the substep's, at its end
RWStructuredBuffer<float4> positions;
RWStructuredBuffer<float4> rigid_pushes;
RWStructuredBuffer<float4> rigid_contacts;
RWStructuredBuffer<float4> rigid_forces;
RWStructuredBuffer<ParticleAttachment> attachments;
RWStructuredBuffer<float4> orientations;
StructuredBuffer<float> orientation_weights;

groupshared float4 block_x[CRESSIM_BLOCK];
static uint block_first;  // the env's first particle
#define NEIGHBOR_POSITION(j) block_x[(j) - block_first]
#define ATTACHED_POSITION(i) block_x[(i) - block_first]
