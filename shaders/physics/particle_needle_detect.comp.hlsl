// Suturing, once a substep before the solver iterations (docs/particles.md, "Suturing"); one
// thread per needle. First the records' states move on by what the last substep did: an
// indented surface point whose push reached the needle's puncture force, or that the tip has
// pushed its puncture depth past where it met it, is punctured (it now lies
// on the path at the tip and slides along it); one the tip no longer pushes (it backed away the
// way it came, past the surface point) is let go; a punctured point the needle has slid back off (s < 0, before the tip) is
// let go. Then, while no point is being indented, the tip's move over the substep is tested
// against the env's soft-body surface (in each triangle's frame, from a substep back:
// start_against): the first triangle it crosses, either way (in at an entry, out at an exit),
// starts an indented point there. Triangles that share a corner with a point
// punctured within the tip's first 10 % are skipped: the tip has just gone through there.
#include "particle_needle.hlsli"

RWStructuredBuffer<float4> needle_states;
RWStructuredBuffer<uint4> phases;
StructuredBuffer<float4> prev_positions;  // at the substep's start: how far each triangle moved
StructuredBuffer<uint4> initial_phases;
static const float RETREAT = 1e-5;  // m behind the surface point: the tip no longer touches it  // per needle: xyz the tip at the last substep, w its push (N; < 0: no tip yet)

// the segment p0 -> p1 against triangle (a, b, c): t along the segment and the barycentric
// weights of a and b, or t < 0 for none
float4 crossing(float3 p0, float3 p1, float3 a, float3 b, float3 c) {
  const float3 d = p1 - p0, e1 = b - a, e2 = c - a;
  const float3 h = cross(d, e2);
  const float det = dot(e1, h);
  if (abs(det) < 1e-14) return float4(-1, 0, 0, 0);
  const float3 s = p0 - a;
  const float u = dot(s, h) / det;
  const float3 qv = cross(s, e1);
  const float v = dot(d, qv) / det;
  const float t = dot(e2, qv) / det;
  // a little past the edges and the ends: a crossing exactly on an edge shared by two triangles (a
  // needle in a plane of the mesh), or a tip that lands exactly on the surface at a substep's end
  // (the next segment then starts on it), is missed by both to rounding otherwise (it was, on an
  // H100, not on lavapipe)
  const float e = 1e-4;
  if (u < -e || v < -e || u + v > 1 + e || t < -e || t > 1 + e) return float4(-1, 0, 0, 0);
  const float uc = clamp(u, 0.0, 1.0), vc = clamp(v, 0.0, 1.0 - uc);
  return float4(clamp(t, 0.0, 1.0), 1 - uc - vc, uc, 0);  // weights of a, b (c: the rest)
}

// The thread runs through the tissue between an exit and the entry before it (on the path, the
// exit is nearer the tip): its particles there, and within a segment of any puncture, pass
// through soft bodies (PARTICLE_NO_SOFT_CONTACT); elsewhere it lies on the tissue as authored.
void sew(NeedleModel n, Arc a) {
  if (n.ids.y == CRESSIM_NONE) return;
  float s = a.radius * a.angle;
  for (uint i = 0; i < n.ids.z; ++i) {
    const uint k = n.ids.y + i;
    const float l = i + 1 < n.ids.z ? rest_length(k) : 0;  // s by rest lengths, as load_thread's
    float below = -1e30, above = 1e30;
    uint below_side = 1, above_side = 0;
    bool near = false;
    for (uint r = n.records.x; r < n.records.x + n.records.y; ++r) {
      const Puncture p = punctures[r];
      if (p.ids.x != PUNCTURE_THROUGH) continue;
      near = near || abs(p.place.z - s) < 1.5 * max(l, 1e-4);
      if (p.place.z <= s && p.place.z > below) below = p.place.z, below_side = p.ids.z;
      if (p.place.z > s && p.place.z < above) above = p.place.z, above_side = p.ids.z;
    }
    const bool inside = near || (below_side == 0 && above_side == 1);
    const uint authored = initial_phases[k].w & PARTICLE_NO_SOFT_CONTACT;
    phases[k].w = (phases[k].w & ~PARTICLE_NO_SOFT_CONTACT) | (inside ? PARTICLE_NO_SOFT_CONTACT : authored);
    s += l;
  }
}

// The tip's way tested against a triangle: from a substep's way back (a tip that the surface met
// in the previous substep's solve, after that substep's test, lies just past it at this one's
// start: tissue rising under gravity past a descending tip was crossed by neither test), in the
// triangle's frame (the start carried along by the triangle's own move over this substep, its
// corners' mean, predicted place against place at the substep's start). A crossing already taken
// is not taken again (the fresh test below).
float3 start_against(uint3 c, float3 start, float3 tip) {
  const float3 moved = positions[c.x].xyz + positions[c.y].xyz + positions[c.z].xyz -
                       prev_positions[c.x].xyz - prev_positions[c.y].xyz - prev_positions[c.z].xyz;
  return start + moved / 3 - (tip - start);
}

// one workgroup per needle: its first thread moves the records on and writes the result, all of
// them test the env's triangles (a serial scan of every triangle each substep was most of a step)
static const uint SCAN_THREADS = 64;
groupshared float scan_t[SCAN_THREADS];
groupshared uint scan_tri[SCAN_THREADS];
groupshared bool scan_on;

[numthreads(SCAN_THREADS, 1, 1)]
void main(uint3 group : SV_GroupID, uint3 thread : SV_GroupThreadID) {
  const uint needle = group.x, lane = thread.x;
  if (needle >= pc.item_count) return;
  const NeedleModel n = needles[needle];
  const Arc a = arc_of(n);
  const float3 tip = tip_of(a);
  const float4 state = needle_states[needle];
  const float recent = 0.1 * a.radius * a.angle;
  float push = 0;
  if (lane == 0) {
    bool indenting = false;
    for (uint r = n.records.x; r < n.records.x + n.records.y; ++r) {
      Puncture p = punctures[r];
      if (p.ids.x == PUNCTURE_INDENTING) {
        push = p.place.w;
        const uint3 c = corners(p.ids.y);
        const float3 x0 = positions[c.x].xyz;
        float3 normal = normalize(cross(positions[c.y].xyz - x0, positions[c.z].xyz - x0));
        if (p.ids.z == 0) normal = -normal;
        if (push >= n.arc.z || distance(tip, p.contact.xyz) >= n.puncture.x) {
          p.ids.x = PUNCTURE_THROUGH;
          p.place.z = 0;
          p.contact.w = push;
        } else if (dot(surface_point(c, weights(p)) - tip, normal) < -RETREAT) {
          p.ids.x = PUNCTURE_FREE;  // the tip backed away the way it came
        }
        p.place.w = 0;
      } else if (p.ids.x == PUNCTURE_THROUGH && p.place.z < 0) {
        p.ids.x = PUNCTURE_FREE;
      } else if (p.ids.x == PUNCTURE_THROUGH) {
        // the last substep's force on the thread (the friction limit of this one reads it)
        p.force = p.impulse / (pc.gravity.w * pc.gravity.w);
        p.impulse = float4(0, 0, 0, 0);
      }
      punctures[r] = p;
      indenting = indenting || p.ids.x == PUNCTURE_INDENTING;
    }
    scan_on = state.w >= 0 && !indenting;
  }
  // the other lanes read the records lane 0 just moved on (a point punctured this substep is
  // `fresh`): a barrier on groupshared memory alone leaves those buffer writes unordered
  AllMemoryBarrierWithGroupSync();
  // each lane's first crossing among its share of the triangles
  float best = 2;
  uint best_tri = CRESSIM_NONE;
  if (scan_on) {
    for (uint k = n.records.z + lane; k < n.records.z + n.records.w; k += SCAN_THREADS) {
      const uint3 c = corners(k);
      const float4 hit = crossing(start_against(c, state.xyz, tip), tip, positions[c.x].xyz, positions[c.y].xyz, positions[c.z].xyz);
      if (hit.x < 0 || hit.x >= best) continue;
      bool fresh = false;
      for (uint r = n.records.x; r < n.records.x + n.records.y && !fresh; ++r) {
        const Puncture p = punctures[r];
        if (p.ids.x != PUNCTURE_THROUGH || p.place.z > recent) continue;
        const uint3 o = corners(p.ids.y);
        fresh = any(c == o.x) || any(c == o.y) || any(c == o.z);
      }
      if (fresh) continue;
      best = hit.x;
      best_tri = k;
    }
  }
  scan_t[lane] = best;
  scan_tri[lane] = best_tri;
  GroupMemoryBarrierWithGroupSync();
  if (lane != 0) return;
  for (uint l = 1; l < SCAN_THREADS; ++l)
    if (scan_t[l] < best || (scan_t[l] == best && scan_tri[l] < best_tri)) best = scan_t[l], best_tri = scan_tri[l];
  if (best_tri != CRESSIM_NONE) {
    const uint3 c = corners(best_tri);
    const float3 x0 = positions[c.x].xyz, x1 = positions[c.y].xyz, x2 = positions[c.z].xyz;
    const float3 from = start_against(c, state.xyz, tip);
    const float4 hit = crossing(from, tip, x0, x1, x2);
    for (uint r = n.records.x; r < n.records.x + n.records.y; ++r) {
      if (punctures[r].ids.x != PUNCTURE_FREE) continue;
      Puncture p;
      // the side it came from by its way across (its start may lie on the surface itself); w: no knot
      p.ids = uint4(PUNCTURE_INDENTING, best_tri, dot(tip - from, cross(x1 - x0, x2 - x0)) < 0 ? 1 : 0, 0);
      p.place = float4(hit.yz, 0, 0);
      p.contact = float4(lerp(from, tip, best), 0);
      p.force = p.impulse = float4(0, 0, 0, 0);
      punctures[r] = p;
      break;
    }
  }
  needle_states[needle] = float4(tip, push);
  sew(n, a);
}
