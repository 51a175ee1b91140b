// Elastic tets (stable Neo-Hookean, particle_model.cpp elastic_tets), solved per particle as in
// Vertex Block Descent (Chen et al. 2024): a thread takes one particle of the colour and moves it
// by a Newton step on its share of the substep's incremental potential
//   G(x) = m / (2 h^2) |x - y|^2 + sum over its tets of V0 psi(F),   y = x_prev + h v (inertia),
// with the other corners held. Particles of one colour share no tet, so the threads do not race.
// The energy is a function of positions alone (no multipliers carried through the substep): a
// body at rest is at the energy's minimum whatever the iteration count, so stiffness does not
// follow the solver budget as it does with XPBD constraints solved short of convergence.
//
// Per tet: F = Ds Dm^-1, Ds = [x1 - x0, x2 - x0, x3 - x0]; corner k moves F by u b_k^T with b_k
// the row k-1 of Dm^-1 (b_0 = minus their sum). With P = mu F + lambda (J - alpha) cof(F):
//   force on corner k   = -V0 P b_k
//   Hessian of corner k = V0 (mu |b_k|^2 I + lambda c c^T),  c = cof(F) b_k
// (det F is linear along u b_k^T, so the J term adds no curvature: the block is positive definite
// and needs no projection).
// Contacts with static and kinematic colliders are part of the same step (contact_step below):
// the step is constrained to the collider's surface with Coulomb friction, so a body resting or
// pressed on a surface is at the energy's minimum with the contact force in the balance. Contacts
// projected after the solve instead made a resting 5 kPa block 2.7 times too soft and a
// frictionless one spread without end. Dynamic bodies share their contacts in the gather.
// Two kinds of build (cmake/shaders.cmake): by default a thread per particle of one colour, a
// dispatch per colour; with CRESSIM_BLOCK = N one workgroup per env (of at most N particles) that
// loads the env's particles into group memory and solves every colour in turn, `item_offset` times
// over (a group barrier between colours): one dispatch where the first needs colours x
// iterations, and for small bodies in many envs the dispatches, not the arithmetic, are the cost.
#include "cressim/layout.h"
#include "cressim/particle.h"
#include "cressim/quat.h"
#include "cressim/rigid.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<ParticleConstraint> constraints;  // particles; params (V0, mu, lambda, alpha)
StructuredBuffer<float4> record_rows;              // Dm^-1, 3 rows a tet
StructuredBuffer<uint> cut;                        // control.particle_tet_cut: nonzero removes the tet
StructuredBuffer<uint> vertices;                   // particles grouped by colour
StructuredBuffer<uint2> vertex_records;            // (first, count) into vertex_corners
StructuredBuffer<uint> vertex_corners;             // tet * 4 + corner
StructuredBuffer<uint4> phases;
StructuredBuffer<float4> prev_positions;
StructuredBuffer<float4> velocities;
StructuredBuffer<ParticleObject> objects;
StructuredBuffer<BodyModel> bodies;
RWStructuredBuffer<float4> positions;
// per particle, this iteration: xyz the load it puts on what holds it (N: the force of its contact
// on a kinematic body, or the force left unbalanced where a rigid attachment holds it), w body + 1
// (0: none)
RWStructuredBuffer<float4> tet_contact_forces;
RWStructuredBuffer<float4> rigid_contacts;  // xyz the contact point on that body
// suture punctures' grip on the tissue (particle_needle_solve): per particle sum K T and sum K, a
// spring of stiffness K toward T in the particle's energy (0: none; one element unless has_pins)
StructuredBuffer<float4> tet_pins;
StructuredBuffer<ParticleAttachment> attachments;

#include "particle_collide.hlsli"

#ifdef CRESSIM_BLOCK
StructuredBuffer<ParticleEnvRange> env_ranges;
StructuredBuffer<uint2> env_colours;  // (first, count) into `vertices` per env and colour
groupshared float4 block_x[CRESSIM_BLOCK];
static uint block_first;  // the env's first particle
float4 load_x(uint i) { return block_x[i - block_first]; }
void store_x(uint i, float3 x) { block_x[i - block_first].xyz = x; }
#else
float4 load_x(uint i) { return positions[i]; }
void store_x(uint i, float3 x) { positions[i].xyz = x; }
#endif

// H x = b for a symmetric positive definite H, by its adjugate
float3 solve3(float3x3 H, float3 b) {
  const float3 a0 = cross(H[1], H[2]), a1 = cross(H[2], H[0]), a2 = cross(H[0], H[1]);
  return (a0 * b.x + a1 * b.y + a2 * b.z) / dot(H[0], a0);
}

// The Newton step x = xi + H^-1 f, held out of the env's static and kinematic colliders: where x
// overlaps one, try the point on its surface that does not slip against it over the substep (x0
// the substep's start); keep it when the contact force that holds it there, H (stick - xi) - f,
// lies in the friction cone, else slide on the surface with the Coulomb force mu F_n along that
// force's tangential part. Colliders are taken in turn, each adding its force to f; the force on
// the last kinematic body touched (w body + 1) and the contact point are kept in on_body, touch.
void contact_one(inout float3 x, float3 xi, float3x3 H, inout float3 f, float3 x0, float r, float object_friction,
                 ColliderModel cm, ColliderPose s, inout float4 on_body, inout float3 touch) {
  float3 n;
  float depth;
  if (!sphere_penetration(x, r, cm, s, n, depth)) return;
  float3 stick = x + depth * n;
  const float3 slip = stick - x0 - surface_motion(s, stick, pc.gravity.w);
  stick -= slip - dot(slip, n) * n;
  const float3 hold = mul(H, stick - xi) - f;
  const float fn = dot(hold, n), ft = length(hold - fn * n);
  const float mu = contact_friction(object_friction, cm);
  float3 force = hold;
  if (ft > mu * fn) {
    float3 d = n + (ft > 1e-20 ? mu / ft * (hold - fn * n) : float3(0, 0, 0));
    float3 g = solve3(H, d);
    if (!(dot(g, n) > 0)) {  // friction that would pull it into the surface: take the normal alone
      d = n;
      g = solve3(H, n);
    }
    const float push = dot(stick - x, n) / dot(g, n);
    force = push * d;
    stick = x + push * g;
  }
  x = stick;
  f += force;
  if (cm.ids.x != CRESSIM_NONE) {
    on_body = float4(on_body.xyz - force, float(cm.ids.x + 1));
    touch = x - r * n;
  }
}

static const uint BATCH = 4;  // tets or colliders whose loads are issued together

bool moves_freely(ColliderModel cm) { return cm.ids.x != CRESSIM_NONE && bodies[cm.ids.x].inv_inertia.w > 0; }

float4 contact_step(inout float3 x, float3 xi, float3x3 H, float3 f, float3 x0, uint4 ph, out float3 touch) {
  touch = x;
  float4 on_body = float4(0, 0, 0, 0);
  const EnvRigidRange er = env_rigid_ranges[ph.z];
  const float r = objects[ph.y].material.x, object_friction = objects[ph.y].material.y;
  const uint end = er.bodies.z + er.bodies.w;
  for (uint c = er.bodies.z; c < end; c += BATCH) {  // loads in batches, as the tets' (solve)
    ColliderModel cm[BATCH];
    [unroll] for (uint u = 0; u < BATCH; ++u) cm[u] = colliders[min(c + u, end - 1)];
    ColliderPose pose[BATCH];
    bool skip[BATCH];
    [unroll] for (uint u = 0; u < BATCH; ++u) {
      skip[u] = c + u >= end || moves_freely(cm[u]) || !meets_particles(cm[u]);
      pose[u] = collider_pose(cm[u]);
    }
    [unroll] for (uint u = 0; u < BATCH; ++u)
      if (!skip[u]) contact_one(x, xi, H, f, x0, r, object_friction, cm[u], pose[u], on_body, touch);
  }
  return on_body;
}

// one tet's force and Hessian block on its corner k (header comment)
void add_tet(inout float3 f, inout float3x3 H, ParticleConstraint rec, float3 r0, float3 r1, float3 r2, uint k) {
  const float3 x0 = load_x(rec.particles.x).xyz;
  const float3 d1 = load_x(rec.particles.y).xyz - x0, d2 = load_x(rec.particles.z).xyz - x0,
               d3 = load_x(rec.particles.w).xyz - x0;
  // columns of F = d1 r0^T + d2 r1^T + d3 r2^T
  const float3 f0 = d1 * r0.x + d2 * r1.x + d3 * r2.x;
  const float3 f1 = d1 * r0.y + d2 * r1.y + d3 * r2.y;
  const float3 f2 = d1 * r0.z + d2 * r1.z + d3 * r2.z;
  const float3 c0 = cross(f1, f2), c1 = cross(f2, f0), c2 = cross(f0, f1);  // columns of cof(F)
  const float J = dot(f0, c0);
  const float3 b = k == 0 ? -(r0 + r1 + r2) : (k == 1 ? r0 : (k == 2 ? r1 : r2));
  const float V0 = rec.params.x, mu = rec.params.y, lambda = rec.params.z, alpha = rec.params.w;
  const float3 Fb = f0 * b.x + f1 * b.y + f2 * b.z;
  const float3 cb = c0 * b.x + c1 * b.y + c2 * b.z;
  f -= V0 * (mu * Fb + lambda * (J - alpha) * cb);
  const float s = V0 * mu * dot(b, b), l = V0 * lambda;
  H += float3x3(s + l * cb.x * cb.x, l * cb.x * cb.y, l * cb.x * cb.z,
                l * cb.y * cb.x, s + l * cb.y * cb.y, l * cb.y * cb.z,
                l * cb.z * cb.x, l * cb.z * cb.y, s + l * cb.z * cb.z);
}

// one Newton step of the particle at `vertices[v]`
void solve(uint v) {
  const uint i = vertices[v];
  const float4 xi = load_x(i);
  if (xi.w <= 0 || (phases[i].w & PARTICLE_ACTIVE) == 0) return;  // fixed, kinematic or inactive
  const float h = pc.gravity.w, m_h2 = 1 / (xi.w * h * h);
  const float3 y = prev_positions[i].xyz + h * velocities[i].xyz;  // velocities hold v + h g here
  float3 f = m_h2 * (y - xi.xyz);
  float3x3 H = float3x3(m_h2, 0, 0, 0, m_h2, 0, 0, 0, m_h2);
  const uint2 range = vertex_records[v];
  // the tets in batches whose loads are all issued before any is used: one after the other, each
  // tet's two dependent loads were a serial chain of memory round trips per particle
  for (uint n = 0; n < range.y; n += BATCH) {
    uint rc[BATCH];
    [unroll] for (uint u = 0; u < BATCH; ++u) rc[u] = vertex_corners[range.x + min(n + u, range.y - 1)];
    uint off[BATCH];
    ParticleConstraint rec[BATCH];
    float3 rows[BATCH][3];
    [unroll] for (uint u = 0; u < BATCH; ++u) {
      const uint t = rc[u] >> 2;
      off[u] = cut[t];
      rec[u] = constraints[t];
      [unroll] for (uint j = 0; j < 3; ++j) rows[u][j] = record_rows[3 * t + j].xyz;
    }
    [unroll] for (uint u = 0; u < BATCH; ++u)
      if (n + u < range.y && off[u] == 0) add_tet(f, H, rec[u], rows[u][0], rows[u][1], rows[u][2], rc[u] & 3);
  }
  // Held rigidly by an attachment slot (particle_attach places it on its body): not moved here; the
  // force left unbalanced is what the body bears (a tool reads the weight of tissue it lifts).
  const uint per_env = pc.attachment_count / max(pc.env_count, 1u), env = phases[i].z;
  for (uint s = env * per_env; s < (env + 1) * per_env; ++s) {
    const ParticleAttachment at = attachments[s];
    if (at.ids.z == ATTACH_FREE || at.ids.x != i || at.local.w > 0) continue;
    tet_contact_forces[i] = float4(f, float(at.ids.y + 1));
    rigid_contacts[i] = float4(xi.xyz, 0);
    return;
  }
  if (pc.has_pins != 0) {
    const float4 pin = tet_pins[i];
    f += pin.xyz - pin.w * xi.xyz;
    H += float3x3(pin.w, 0, 0, 0, pin.w, 0, 0, 0, pin.w);
  }
  if (!(determinant(H) > 0)) return;
  float3 x = xi.xyz + solve3(H, f);
  float4 load = float4(f, 0);
  if (pc.has_rigid != 0) {
    float3 touch;
    const float4 on_body = contact_step(x, xi.xyz, H, f, prev_positions[i].xyz, phases[i], touch);
    if (on_body.w > 0) {
      load = on_body;
      rigid_contacts[i] = float4(touch, 0);
    }
  }
  tet_contact_forces[i] = load;
  store_x(i, x);
}

#ifndef CRESSIM_BLOCK

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  if (id.x < pc.item_count) solve(pc.item_offset + id.x);
}

#else

static const uint BLOCK_THREADS = 128;

[numthreads(BLOCK_THREADS, 1, 1)]
void main(uint3 group : SV_GroupID, uint3 thread : SV_GroupThreadID) {
  const uint env = group.x, lane = thread.x, colours = pc.item_count;
  block_first = env_ranges[env].range.x;
  const uint count = env_ranges[env].range.y;
  for (uint i = lane; i < count; i += BLOCK_THREADS) block_x[i] = positions[block_first + i];
  GroupMemoryBarrierWithGroupSync();
  for (uint pass = 0; pass < pc.item_offset; ++pass) {
    for (uint k = 0; k < colours; ++k) {
      const uint2 r = env_colours[env * colours + k];
      for (uint j = lane; j < r.y; j += BLOCK_THREADS) solve(r.x + j);
      GroupMemoryBarrierWithGroupSync();
    }
  }
  for (uint i = lane; i < count; i += BLOCK_THREADS) positions[block_first + i] = block_x[i];
}

#endif
