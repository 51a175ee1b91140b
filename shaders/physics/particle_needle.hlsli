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
StructuredBuffer<float4> initial_positions;  // as authored: the thread's rest lengths
StructuredBuffer<uint> surface;  // particles.surface: three particles a triangle
#ifdef NEEDLE_MOVES_BODY  // particle_needle_load: a free needle is moved by its punctures
RWStructuredBuffer<float4> body_positions;
RWStructuredBuffer<float4> body_rotations;
RWStructuredBuffer<float4> body_linear_velocities;
RWStructuredBuffer<float4> body_angular_velocities;
#else
StructuredBuffer<float4> body_positions;
StructuredBuffer<float4> body_rotations;
StructuredBuffer<float4> body_linear_velocities;
StructuredBuffer<float4> body_angular_velocities;
#endif

static const float PUNCTURE_GRIP = 1e4;  // N/m: the tissue's grip on the needle, 0.1 mm of give under 1 N

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

// The thread's particles by path parameter: where along the path each one sits (the needle's
// length plus the thread's up to it, by its segments' rest lengths: s names a material point of
// the thread, so a punctured point that holds s holds the thread there whatever the thread before
// it does, stretched or cut), taken once a pass (load_thread): a pass looks points up along the
// thread many times, and walking it from its start each time was most of a step's cost.
// a thread segment's rest length: as authored (the strand's stretch constraints rest there too)
float rest_length(uint k) { return distance(initial_positions[k].xyz, initial_positions[k + 1].xyz); }

static const uint MAX_THREAD = 256;  // particles of a needle's thread (scene validation enforces it)
static float thread_at[MAX_THREAD];
static uint thread_count;

void load_thread(NeedleModel n, Arc a) {
  thread_count = n.ids.y == CRESSIM_NONE ? 0 : min(n.ids.z, MAX_THREAD);
  float s = a.radius * a.angle;
  for (uint i = 0; i < thread_count; ++i) {
    if (i > 0) s += rest_length(n.ids.y + i - 1);
    thread_at[i] = s;
  }
}

// the thread segment whose span holds s (the first or last beyond either end)
uint segment_at(float s) {
  uint lo = 0, hi = thread_count - 1;  // thread_at[lo] <= s < thread_at[hi] once narrowed
  while (hi - lo > 1) {
    const uint mid = (lo + hi) / 2;
    if (thread_at[mid] <= s) lo = mid; else hi = mid;
  }
  return lo;
}

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
  if (s <= a.radius * a.angle || thread_count < 2) {
    const float phi = a.angle - s / a.radius;  // beyond either end: on the arc's extension
    r.x = arc_point(a, phi);
    r.t = quat_rotate(a.q, float3(sin(phi), -cos(phi), 0));
    return r;
  }
  const uint i = segment_at(s);
  const float3 x0 = positions[n.ids.y + i].xyz, x1 = positions[n.ids.y + i + 1].xyz;
  const float l = thread_at[i + 1] - thread_at[i];
  r.f = l > 1e-9 ? clamp((s - thread_at[i]) / l, 0.0, 1.0) : 0;
  r.x = lerp(x0, x1, r.f);
  r.t = dot(x1 - x0, x1 - x0) > 1e-18 ? normalize(x1 - x0) : float3(1, 0, 0);
  r.segment = n.ids.y + i;
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
  if (thread_count < 2 || s <= needle_length) {
    const float3 local = quat_unrotate(a.q, x - a.centre);
    float phi = atan2(local.y, local.x);  // in (-pi, pi]; the arc runs over [0, angle]
    if (phi < -0.5 * (2 * 3.14159265 - a.angle)) phi += 2 * 3.14159265;
    const float raw = (a.angle - phi) * a.radius;
    // past the tail: onto the thread, which the puncture then draws through whatever way it hangs
    if (raw > needle_length && thread_count >= 2) return min(needle_length + 1e-5, s + reach);
    const float sa = clamp(raw, max(s - reach, 0.0), min(s + reach, needle_length));
    const float3 px = arc_point(a, a.angle - sa / a.radius);
    best = sa;
    best_d2 = dot(x - px, x - px);
  }
  if (thread_count < 2) return best;
  const uint seg = segment_at(max(s, needle_length));
  for (uint i = seg >= 2 ? seg - 2 : 0; i + 1 < thread_count && i <= seg + 2; ++i) {
    const float3 x0 = positions[n.ids.y + i].xyz, x1 = positions[n.ids.y + i + 1].xyz;
    const float3 e = x1 - x0;
    const float l = thread_at[i + 1] - thread_at[i];
    const float f = dot(e, e) > 1e-18 ? clamp(dot(x - x0, e) / dot(e, e), 0.0, 1.0) : 0;
    const float3 px = x0 + f * e;
    const float d2 = dot(x - px, x - px);
    const float sp = thread_at[i] + f * l;
    if (d2 < best_d2 && abs(sp - s) <= reach) {
      best_d2 = d2;
      best = sp;
    }
  }
  return best;
}

// the path's length: the needle and its thread
float path_length(Arc a) {
  return thread_count ? thread_at[thread_count - 1] : a.radius * a.angle;
}

uint3 corners(uint tri) { return uint3(surface[3 * tri], surface[3 * tri + 1], surface[3 * tri + 2]); }

float3 weights(Puncture r) { return float3(r.place.x, r.place.y, 1 - r.place.x - r.place.y); }

float3 surface_point(uint3 c, float3 b) {
  return b.x * positions[c.x].xyz + b.y * positions[c.y].xyz + b.z * positions[c.z].xyz;
}
