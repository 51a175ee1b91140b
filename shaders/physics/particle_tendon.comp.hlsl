// Tendons routed through the disks of a strand (a cable-driven continuum robot; docs/particles.md,
// "Routed cables"). A tendon's hole in disk k is h_k = x_k + R_k o (o in the disk's frame), and its
// length L = sum |h_k+1 - h_k| from the first disk to the last: it slides freely through the holes,
// so only this length is constrained and its tension is the same all along. The gradient of L at
// hole k is g_k = u_k-1 - u_k (u the unit directions of the route's spans): the force -T g_k pulls
// each disk toward both its neighbours' holes, and the tip disk back toward the base.
// One thread per robot, its tendons one after the other (they share disks). item_offset 0: the
// length constraint of tendons in displacement mode, C = L - (L0 - d) <= 0 (taut only, XPBD,
// each solver iteration); 1: the force of tendons in tension mode, once a substep before the
// iterations (a turn h^2 W tau, as gravity's position change is). The pull acts on the disks'
// frames alone (the torques r_k x F_k; docs/particles.md says why); a disk whose frame is clamped
// (its segment's two particles fixed) does not turn.
#include "cressim/layout.h"
#include "cressim/particle.h"
#include "cressim/quat.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<float4> positions;
RWStructuredBuffer<float4> orientations;
StructuredBuffer<float> orientation_weights;
StructuredBuffer<TendonRobot> tendon_robots;
StructuredBuffer<uint2> tendon_disks;   // (particle, frame)
StructuredBuffer<Tendon> tendons;
StructuredBuffer<float2> tendon_commands;   // x mode (TENDON_*), y metres or newtons
RWStructuredBuffer<float4> tendon_states;   // x length (m), y tension (N), z target length (m; displacement), w mode
RWStructuredBuffer<float> tendon_lambdas;   // the substep's multiplier (cleared each substep)

float3 hole(uint2 disk, float2 o) {
  return positions[disk.x].xyz + quat_rotate(orientations[disk.y], float3(o, 0));
}

// the frame's inverse inertia for a turn (the stretch-shear pass's convention: 4 w; 0 clamped)
float turn_weight(uint2 disk) {
  return 4 * orientation_weights[disk.y];
}

// One walk along the route, disk by disk: the route's length and its generalized inverse mass
// sum_k W |r_k x g_k|^2 (only the frames turn: below), and, for a step, each disk's frame turned by
// -step W (r_k x g_k). The gradient at a disk uses the spans' directions before it moves: the next
// hole is taken before the disk turns, and a disk's own hole does not depend on the one before.
float2 walk(uint first, uint count, float2 o, float step) {
  float length = 0, weight = 0;
  float3 u_prev = float3(0, 0, 0);
  float3 h = hole(tendon_disks[first], o);
  for (uint k = 0; k < count; ++k) {
    const uint2 disk = tendon_disks[first + k];
    float3 u = float3(0, 0, 0);
    float3 next = h;
    if (k + 1 < count) {
      next = hole(tendon_disks[first + k + 1], o);
      const float span = distance(next, h);
      length += span;
      u = span > 1e-12 ? (next - h) / span : float3(0, 0, 0);
    }
    const float3 rg = cross(h - positions[disk.x].xyz, u_prev - u);
    const float W = turn_weight(disk);
    weight += W * dot(rg, rg);
    if (step != 0 && W > 0) orientations[disk.y] = quat_add_rotation(orientations[disk.y], -step * W * rg);
    u_prev = u;
    h = next;
  }
  return float2(length, weight);
}

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  if (id.x >= pc.item_count) return;
  const uint4 robot = tendon_robots[id.x].range;
  const float h2 = pc.gravity.w * pc.gravity.w;
  for (uint t = robot.z; t < robot.z + robot.w; ++t) {
    const Tendon td = tendons[t];
    const float2 command = tendon_commands[t];
    const uint mode = uint(command.x);
    const float2 lw = walk(robot.x, robot.y, td.route.xy, 0);
    if (pc.item_offset == 1) {
      if (mode != TENDON_TENSION) continue;
      const float tension = max(command.y, 0.0);
      walk(robot.x, robot.y, td.route.xy, h2 * tension);
      tendon_states[t] = float4(lw.x, tension, 0, mode);
      continue;
    }
    if (mode != TENDON_DISPLACEMENT) {
      if (mode != TENDON_TENSION) tendon_states[t] = float4(lw.x, 0, 0, mode);
      continue;
    }
    // taut only: the multiplier stays <= 0 (a tendon pulls, never pushes)
    const float target = td.route.z - command.y;
    const float alpha = td.route.w / h2;
    const float lambda = tendon_lambdas[t];
    const float C = lw.x - target;
    float dl = (-C - alpha * lambda) / max(lw.y + alpha, 1e-20);
    dl = min(lambda + dl, 0.0) - lambda;
    tendon_lambdas[t] = lambda + dl;
    if (dl != 0) walk(robot.x, robot.y, td.route.xy, -dl);
    tendon_states[t] = float4(lw.x, -(lambda + dl) / h2, target, mode);
  }
}
