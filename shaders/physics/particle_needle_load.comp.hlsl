// Frame end, one thread per needle (docs/particles.md, "Suturing"): where a needle's load goes.
// The tissue acts on the needle where it holds it, at a surface point the tip pushes (indenting)
// or that is threaded on the needle, with the grip spring's force K (x - p) (x the surface point,
// p the tip or the point of the needle it is pinned to: particle_needle_solve).
// - Held (control.needle_holders: the holding body's row + 1), the needle is kinematic and the
//   holder bears its weight and those forces: they are added to the holder's contact force and
//   torque (what a tool reports) and, where the holder is dynamic, act on it over the next frame
//   as a held particle's load does (particle_rigid_hold: a change of its velocity).
// - The taut thread's pull on the tail (its tension along its way from the tail, once the knot
//   has caught: particles.needle_threads) is among them; a slack thread's weight and drag are not.
// A needle let go of (dynamic) is held by its punctures in the solve instead (particle_needle_solve).
#define NEEDLE_MOVES_BODY  // the holder's velocity
#include "particle_needle.hlsli"

StructuredBuffer<BodyModel> bodies;
StructuredBuffer<float4> body_dynamic_inertia;  // the needle's mass while it is kinematic
StructuredBuffer<uint> needle_holders;
StructuredBuffer<float4> needle_threads;
RWStructuredBuffer<float4> body_contact_forces;
RWStructuredBuffer<float4> body_contact_torques;

// Where the tissue holds the needle at record p: the surface point x and the point of the needle
// it is pinned to; false where it holds none (free, on the thread, behind the tip)
bool grip(NeedleModel n, Arc a, Puncture p, out float3 x, out float3 on_needle) {
  x = on_needle = float3(0, 0, 0);
  if (p.ids.x == PUNCTURE_FREE) return false;
  const uint3 c = corners(p.ids.y);
  x = surface_point(c, weights(p));
  if (p.ids.x == PUNCTURE_INDENTING) {
    on_needle = tip_of(a);
    const float3 x0 = positions[c.x].xyz;
    float3 normal = normalize(cross(positions[c.y].xyz - x0, positions[c.z].xyz - x0));
    if (p.ids.z == 0) normal = -normal;
    return dot(x - on_needle, normal) > 0;
  }
  if (p.place.z > a.radius * a.angle) return false;  // on the thread
  on_needle = path_at(n, a, p.place.z).x;
  return true;
}

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  if (id.x >= pc.item_count) return;
  const NeedleModel n = needles[id.x];
  const uint b = n.ids.x;
  thread_count = 0;  // the needle's own arc alone (path_at)
  const float dt = pc.gravity.w * pc.grid.w;
  const uint holder = needle_holders[id.x];
  if (holder != 0) {  // a needle let go of is held by its punctures instead (particle_needle_solve)
    const uint h = holder - 1;
    const Arc a = arc_of(n);
    const float3 origin = body_positions[h].xyz;
    const float mass = body_dynamic_inertia[b].w > 0 ? 1 / body_dynamic_inertia[b].w : 0;
    float3 f = mass * pc.gravity.xyz, t = cross(body_positions[b].xyz - origin, f);
    for (uint r = n.records.x; r < n.records.x + n.records.y; ++r) {
      float3 x, on_needle;
      if (!grip(n, a, punctures[r], x, on_needle)) continue;
      const float3 F = PUNCTURE_GRIP * (x - on_needle);
      f += F;
      t += cross(on_needle - origin, F);
    }
    const float4 thread = needle_threads[id.x];
    f += thread.x * thread.yzw;
    t += cross(tail_of(a) - origin, thread.x * thread.yzw);
    body_contact_forces[h].xyz += f;
    body_contact_torques[h].xyz += t;
    const BodyModel m = bodies[h];
    if (m.inv_inertia.w > 0) {
      const float4 q = body_rotations[h];
      body_linear_velocities[h].xyz += m.inv_inertia.w * dt * f;
      body_angular_velocities[h].xyz += dt * quat_rotate(q, m.inv_inertia.xyz * quat_unrotate(q, t));
    }
  }
}
