// What the needle passes share (particle_needle_detect, particle_needle_solve): the needle's arc
// in the world at the substep, its path (the arc from the tip to the tail, then the thread) and
// the surface point a puncture record names.
#include "cressim/layout.h"
#include "cressim/particle.h"
#include "cressim/quat.h"
#include "cressim/rigid.h"

[[vk::push_constant]] ConstantBuffer<ParticleConstants> pc;
StructuredBuffer<NeedleModel> needles;
RWStructuredBuffer<Puncture> punctures;
RWStructuredBuffer<float4> positions;
StructuredBuffer<uint> surface;  // particles.surface: three particles a triangle
StructuredBuffer<float4> body_positions;
StructuredBuffer<float4> body_rotations;
StructuredBuffer<float4> body_linear_velocities;
StructuredBuffer<float4> body_angular_velocities;

// the arc's frame in the world at the end of this substep (the rigid step ran the whole frame)
struct Arc {
  float3 centre;
  float4 q;
  float radius, angle;
};

Arc arc_of(NeedleModel n) {
  const uint b = n.ids.x;
  const float frame_left = pc.gravity.w * pc.grid.w * (1 - pc.grid.y);
  const float3 p = body_positions[b].xyz - body_linear_velocities[b].xyz * frame_left;
  const float4 q = quat_add_rotation(body_rotations[b], -body_angular_velocities[b].xyz * frame_left);
  Arc a;
  a.centre = p + quat_rotate(q, n.center.xyz);
  a.q = quat_mul(q, n.rotation);
  a.radius = n.arc.x;
  a.angle = n.arc.y;
  return a;
}

float3 arc_point(Arc a, float phi) { return a.centre + quat_rotate(a.q, a.radius * float3(cos(phi), sin(phi), 0)); }
float3 tip_of(Arc a) { return arc_point(a, a.angle); }
float3 tail_of(Arc a) { return arc_point(a, 0); }

// A point of the path at s (m from the tip): its position, unit tangent toward the tail and on,
// and on the thread the segment's first particle and the share of the second (else NONE)
struct PathPoint {
  float3 x, t;
  uint segment;
  float f;
};

PathPoint path_at(NeedleModel n, Arc a, float s) {
  PathPoint r;
  r.segment = CRESSIM_NONE;
  r.f = 0;
  const float needle_length = a.radius * a.angle;
  if (s <= needle_length || n.ids.y == CRESSIM_NONE) {
    const float phi = a.angle - s / a.radius;  // beyond either end: on the arc's extension
    r.x = arc_point(a, phi);
    r.t = quat_rotate(a.q, float3(sin(phi), -cos(phi), 0));
    return r;
  }
  // along the thread from its first particle (tied to the tail)
  float left = s - needle_length;
  const uint first = n.ids.y, count = n.ids.z;
  for (uint i = 0; i + 1 < count; ++i) {
    const float3 x0 = positions[first + i].xyz, x1 = positions[first + i + 1].xyz;
    const float l = distance(x0, x1);
    if (left <= l || i + 2 == count) {
      r.f = l > 1e-9 ? clamp(left / l, 0.0, 1.0) : 0;
      r.x = lerp(x0, x1, r.f);
      r.t = l > 1e-9 ? (x1 - x0) / l : float3(1, 0, 0);
      r.segment = first + i;
      return r;
    }
    left -= l;
  }
  r.x = positions[first].xyz;
  r.t = float3(1, 0, 0);
  return r;
}

// The path parameter of the path's point nearest to x within `reach` of s (m along the path), on
// the arc and on the thread's segments near s: a punctured point slides along a bending thread
// without leaving it at the next segment's turn, and never jumps to another stretch of the path
// that passes by. A point past the tail looks along the thread only.
float nearest_s(NeedleModel n, Arc a, float3 x, float s, float reach) {
  const float needle_length = a.radius * a.angle;
  float best = s, best_d2 = 1e30;
  // past the tail a point stays on the thread: the thread is pulled into it, the needle is gone
  if (n.ids.y == CRESSIM_NONE || s <= needle_length) {
    const float3 local = quat_unrotate(a.q, x - a.centre);
    float phi = atan2(local.y, local.x);  // in (-pi, pi]; the arc runs over [0, angle]
    if (phi < -0.5 * (2 * 3.14159265 - a.angle)) phi += 2 * 3.14159265;
    const float raw = (a.angle - phi) * a.radius;
    // past the tail: onto the thread, which the puncture then draws through whatever way it hangs
    if (raw > needle_length && n.ids.y != CRESSIM_NONE) return min(needle_length + 1e-5, s + reach);
    const float sa = clamp(raw, max(s - reach, 0.0), min(s + reach, needle_length));
    const float3 px = arc_point(a, a.angle - sa / a.radius);
    best = sa;
    best_d2 = dot(x - px, x - px);
  }
  if (n.ids.y == CRESSIM_NONE) return best;
  // thread segments from two before s's to two after
  float start = needle_length;
  uint seg = 0;
  const uint first = n.ids.y, count = n.ids.z;
  while (seg + 2 < count && start + distance(positions[first + seg].xyz, positions[first + seg + 1].xyz) < s) {
    start += distance(positions[first + seg].xyz, positions[first + seg + 1].xyz);
    ++seg;
  }
  uint lo = seg >= 2 ? seg - 2 : 0;
  for (uint i = lo; i < seg; ++i) start -= distance(positions[first + i].xyz, positions[first + i + 1].xyz);
  for (uint i = lo; i + 1 < count && i <= seg + 2; ++i) {
    const float3 x0 = positions[first + i].xyz, x1 = positions[first + i + 1].xyz;
    const float3 e = x1 - x0;
    const float l = length(e);
    const float f = l > 1e-9 ? clamp(dot(x - x0, e) / (l * l), 0.0, 1.0) : 0;
    const float3 px = x0 + f * e;
    const float d2 = dot(x - px, x - px);
    if (d2 < best_d2 && abs(start + f * l - s) <= reach) {
      best_d2 = d2;
      best = start + f * l;
    }
    start += l;
  }
  return best;
}

// the path's length: the needle and its thread
float path_length(NeedleModel n, Arc a) {
  float l = a.radius * a.angle;
  for (uint i = 0; n.ids.y != CRESSIM_NONE && i + 1 < n.ids.z; ++i)
    l += distance(positions[n.ids.y + i].xyz, positions[n.ids.y + i + 1].xyz);
  return l;
}

uint3 corners(uint tri) { return uint3(surface[3 * tri], surface[3 * tri + 1], surface[3 * tri + 2]); }

float3 weights(Puncture r) { return float3(r.place.x, r.place.y, 1 - r.place.x - r.place.y); }

float3 surface_point(uint3 c, float3 b) {
  return b.x * positions[c.x].xyz + b.y * positions[c.y].xyz + b.z * positions[c.z].xyz;
}
