// Suturing, every solver iteration before the constraint families (docs/particles.md, "Suturing");
// one thread per needle, its records one after the other (they share the thread). The thread's
// first particle (driven: an anchor to the strand's solves) is put at the needle's tail. Where a
// record moves tissue it does so through a stiff spring in the elastic solve (particles.tet_pins,
// PUNCTURE_GRIP N/m on the surface point, shared by its triangle's corners), so that the tissue's
// elasticity and the needle balance in one solve instead of one undoing the other each iteration.
// - Indenting: the surface point is pulled to the tip while the tip pushes it (away from the side
//   it came from); the spring's force along the normal at the substep's last iteration (the
//   tissue's push back on the tip) is the push the puncture test reads.
// - Punctured, on the needle (rigid, driven): the path parameter s slides toward the path's point
//   nearest the surface point by what Coulomb friction cannot hold (position-level friction, as
//   PBD contacts do: the slide sticks within mu times the point's distance from the path), and the
//   tissue goes to the path there.
// - Punctured, on the thread, squeeze 0 (the default, and every shipped scene): the thread, light
//   and slack, is drawn through the puncture (it moves across to it; the tissue stays), s
//   following the nearest point along it (within span_bounds); `friction` acts on the needle
//   only. Once s reaches the path's end, the thread's last particle is a knot: it neither passes
//   nor comes back out, and sits on the tissue there, an anchor to the thread's own solves.
// - Punctured, on the thread, squeeze N > 0 (friction on the thread; docs/particles.md): the
//   puncture holds the thread's material point s (s counts rest lengths: particle_needle.hlsli),
//   its impulse along the thread summed over the substep's iterations and clamped to the capstan
//   limit T_high <= T_low exp(mu theta) + mu N (the tensions from the puncture's force over the
//   last substep; thread_through), along the thread's chord across the puncture. Checked with a
//   rope: Coulomb's threshold of a straight pass and the capstan law at a turn.
// - Once the knot has caught, the thread from the tail through the punctures on it to the knot is
//   a taut string (taut_string): each span between two points holds its thread and bears its
//   stretch's tension, and the thread slides through a puncture only where the two sides'
//   tensions break the capstan law (without friction on the thread: where they differ), so that a
//   stitch pulled tight draws the tissue it passes toward the line and closes a wound; the first
//   span's tension is what the needle's tail bears (particles.needle_threads).
// Each puncture on the thread reports the force it put on it over the last substep (Puncture.force).
#define NEEDLE_MOVES_BODY  // a needle let go of (dynamic) and the tissue it is in share each correction
#include "particle_needle.hlsli"

StructuredBuffer<BodyModel> bodies;
RWStructuredBuffer<float4> tet_pins;  // per particle: sum K T, sum K (cleared each substep)
RWStructuredBuffer<float4> needle_threads;  // per needle: x the thread's tension (N), yzw its way from the tail

static const float TURN_SPAN = 0.003;     // m along the path either side of a puncture: a turn's extent
static const float REACH = 0.002;         // m: the most a punctured point slides along the path an iteration

// the spring that pulls surface point p = sum b_i x_i (corners c) toward `goal`: on corner i the
// force K b_i (goal - p) and the stiffness K b_i, not the K b_i^2 of the energy's own Hessian. The
// corners are solved apart, each against the gap as it was: with K b_i each moves by the whole gap
// where the spring dominates, which moves p by exactly the gap (the sum of the b_i is 1), where
// K b_i^2 would move each by gap / b_i and p by three times the gap, and the solve would diverge.
void pin(uint3 c, float3 b, float3 p, float3 goal, float stiffness = PUNCTURE_GRIP) {
  [unroll] for (uint k = 0; k < 3; ++k) {
    const uint i = c[k];
    if (positions[i].w <= 0 || b[k] <= 0) continue;
    const float K = stiffness * b[k];
    tet_pins[i] += float4(K * (goal - p + positions[i].xyz), K);
  }
}

// The friction that can hold the thread at a puncture (N, along it): the capstan law over the turn
// theta the thread takes there, T_high <= T_low exp(mu theta) + mu N (N: the tissue's squeeze),
// in terms of the force the puncture bears, F (the last substep's): across the thread's mean
// direction it is (T_a + T_b) sin(theta / 2), along it (T_b - T_a) cos(theta / 2). At the limit
// T_b - T_a = ((T_a + T_b)(E - 1) + 2 mu N) / (E + 1), E = exp(mu theta); for a straight pass
// (theta -> 0) this is Coulomb's mu (F across + N).
float holding_force(NeedleModel n, Arc a, float s, float3 x, float3 F, float mu) {
  const float3 ta = normalize(x - path_at(n, a, s - TURN_SPAN).x), tb = normalize(path_at(n, a, s + TURN_SPAN).x - x);
  const float theta = acos(clamp(dot(ta, tb), -1.0, 1.0));
  const float3 t = normalize(ta + tb + 1e-9);
  const float across = length(F - dot(F, t) * t);
  const float half_theta = min(0.5 * theta, 1.4);  // a thread doubled back has no mean direction
  const float per_across = half_theta > 1e-3 ? tanh(mu * half_theta) / sin(half_theta) : mu;
  return cos(half_theta) * (across * per_across + 2 * mu * n.puncture.y / (1 + exp(2 * mu * half_theta)));
}

// A punctured point on the thread holds the thread's material point s (the point of the path at s
// goes to it, the least motion of its segment's two ends); along the thread (its chord across the
// puncture) by no more than the friction can hold over the substep (the impulse along it summed over the iterations and clamped,
// as sequential impulses are), and where that is not enough the thread slides through: s moves on
// by what was left. Across the thread it is held fully; that force (the thread's turn there, and
// its tension across a puncture it crosses) sets what friction can hold.
void thread_through(NeedleModel n, Arc a, inout Puncture p, float3 x, float mu) {
  const PathPoint q = path_at(n, a, p.place.z);
  const uint i0 = q.segment, i1 = q.segment + 1;
  const float w0 = max(positions[i0].w, 0.0), w1 = max(positions[i1].w, 0.0);
  const float g0 = 1 - q.f, g1 = q.f;
  const float3 d = x - q.x;
  const float along = dot(d, q.t);
  if (w0 <= 0) {
    // the segment from the tail (driven): turned about it to run through the puncture, which it
    // passes freely (moving its far end alone by the least motion would take d / f, unbounded near
    // the tail)
    const float3 from = x - positions[i0].xyz;
    if (length(from) > 1e-7)
      positions[i1].xyz = positions[i0].xyz + distance(positions[i0].xyz, positions[i1].xyz) * normalize(from);
    p.place.z += along;
    return;
  }
  const float W = g0 * g0 * w0 + g1 * g1 * w1;
  // the way the thread slides through: its chord across the puncture (at a turn, the bisector of
  // its two sides, which the capstan limit is written along), not the one segment s lies on
  const float3 chord = path_at(n, a, p.place.z + TURN_SPAN).x - path_at(n, a, p.place.z - TURN_SPAN).x;
  const float3 t = dot(chord, chord) > 1e-12 ? normalize(chord) : q.t;
  const float slide = dot(d, t);
  const float3 across = d - slide * t;
  const float h2 = pc.gravity.w * pc.gravity.w;
  const float limit = holding_force(n, a, p.place.z, x, p.force.xyz, mu) * h2;
  const float before = p.impulse.w;
  const float held = clamp(before + slide / W, -limit, limit);
  const float3 push = across / W + (held - before) * t;  // the impulse on the thread, times h
  positions[i0].xyz += w0 * g0 * push;
  positions[i1].xyz += w1 * g1 * push;
  p.impulse = float4(p.impulse.xyz + push, held);
  p.place.z += slide - (held - before) * W;  // what friction did not hold slid through
}

// Without friction the light thread is drawn through the puncture: it moves across to it (the
// least motion of its segment's ends; the segment from the driven tail turned about it), s
// following the path's nearest point.
void slide_through(NeedleModel n, Arc a, inout Puncture p, float3 x, float2 bounds) {
  p.place.z = min(max(nearest_s(n, a, x, p.place.z, REACH), bounds.x), bounds.y);
  const PathPoint q = path_at(n, a, p.place.z);
  if (q.segment == CRESSIM_NONE) return;  // no thread (NONE + 1 would wrap to global particle 0)
  const uint i0 = q.segment, i1 = q.segment + 1;
  const float3 d = x - q.x;
  float3 moved1;
  if (positions[i0].w <= 0) {
    const float3 from = x - positions[i0].xyz;
    moved1 = float3(0, 0, 0);
    if (length(from) > 1e-7)
      moved1 = positions[i0].xyz + distance(positions[i0].xyz, positions[i1].xyz) * normalize(from) - positions[i1].xyz;
  } else {
    const float k = 1 / ((1 - q.f) * (1 - q.f) + q.f * q.f);
    positions[i0].xyz += (1 - q.f) * k * d;
    p.impulse.xyz += (1 - q.f) * k * d / positions[i0].w;
    moved1 = positions[i1].w > 0 ? q.f * k * d : float3(0, 0, 0);
  }
  positions[i1].xyz += moved1;
  if (positions[i1].w > 0) p.impulse.xyz += moved1 / positions[i1].w;
}

// A dynamic needle (let go of) and the tissue it is in: the surface point x and the needle's point
// `on_needle` meet by inverse mass, the needle's at that point and the surface point's (its corners
// by their weights), so that the tissue holds the needle up as much as the needle holds it: a
// stiff pin would drag the tissue along with a falling needle, and a force from it on a needle of
// a few tens of milligrams (dt^2 k / m far above 1) would diverge. The body moves as the particles'
// pushes move it (particle_rigid_push): by dx now, and by the velocity dx / h for the rest of the frame.
void share(NeedleModel n, uint3 c, float3 b, float3 x, float3 on_needle) {
  const uint body = n.ids.x;
  const BodyModel m = bodies[body];
  const float gap = distance(x, on_needle);
  if (gap < 1e-9) return;
  const float3 dir = (x - on_needle) / gap;
  const float4 q = body_rotations[body];
  const float3 rn = quat_unrotate(q, cross(on_needle - body_positions[body].xyz, dir));
  const float3 wc = max(float3(positions[c.x].w, positions[c.y].w, positions[c.z].w), 0.0);
  const float lambda = gap / (m.inv_inertia.w + dot(rn, m.inv_inertia.xyz * rn) + dot(b * b, wc));
  [unroll] for (uint k = 0; k < 3; ++k) positions[c[k]].xyz -= wc[k] * b[k] * lambda * dir;
  const float h = pc.gravity.w, frame_left = h * pc.grid.w * (1 - pc.grid.y);
  const float3 dx = m.inv_inertia.w * lambda * dir, turn = lambda * quat_rotate(q, m.inv_inertia.xyz * rn);
  body_positions[body].xyz += dx * (1 + frame_left / h);
  body_rotations[body] = quat_add_rotation(q, turn * (1 + frame_left / h));
  body_linear_velocities[body].xyz += dx / h;
  body_angular_velocities[body].xyz += turn / h;
}

// N/m: the taut string's grip on the tissue. Each span of the string is held to its thread by a
// position-based solve of its two ends, given to the elastic solve as a spring of STRING_GRIP toward
// there: a span between two tissue points bears T = STRING_GRIP / 2 times its stretch, the span
// from the driven tail STRING_GRIP times it (its give: 0.1 mm at 0.05 N). The tissue settles under
// it at k / (k + STRING_GRIP) an iteration (k its own stiffness there, tens of N/m for 10 kPa): at
// the needle's 10^4 N/m a held tension was still falling seconds later as the tissue crept after it.
static const float STRING_GRIP = 1e3;
static const uint MAX_STRING = 64;  // punctures on a string (scene validation bounds max_punctures)

// The string: the punctured points on the thread in the order of s (the tail before them), as
// they are at the pass's start (the pass moves the thread and pins the tissue, never moves it).
static uint string_records[MAX_STRING];
static float3 string_points[MAX_STRING];
static uint string_count;

void load_string(NeedleModel n, Arc a) {
  string_count = 0;
  const float needle_length = a.radius * a.angle;
  for (uint r = n.records.x; r < n.records.x + n.records.y && string_count < MAX_STRING; ++r) {
    const Puncture p = punctures[r];
    if (p.ids.x != PUNCTURE_THROUGH || p.place.z <= needle_length) continue;
    uint k = string_count++;
    for (; k > 0 && punctures[string_records[k - 1]].place.z > p.place.z; --k) string_records[k] = string_records[k - 1];
    string_records[k] = r;
  }
  for (uint j = 0; j < string_count; ++j) {
    const Puncture p = punctures[string_records[j]];
    string_points[j] = surface_point(corners(p.ids.y), weights(p));
  }
}

// Before the knot has caught, the thread slides through its punctures as a whole: where the tail
// has drawn it through the string's first point (its s below the straight way from the tail),
// every point's s moves on by as much, so the spans between them keep their thread.
void slide_string(Arc a) {
  if (string_count == 0) return;
  const float needle_length = a.radius * a.angle, end = path_length(a);
  const float by = needle_length + distance(tail_of(a), string_points[0]) - punctures[string_records[0]].place.z;
  if (by <= 0) return;
  for (uint j = 0; j < string_count; ++j) {
    const uint r = string_records[j];
    punctures[r].place.z = max(punctures[r].place.z, min(punctures[r].place.z + by, end));
  }
}

// The range of s a punctured point on the loose thread can hold: its place along the string
// (between its neighbours' s), and at least the straight way from the tail for the string's first
// point. Without the latter, where the tail had gone on faster than the first point's s followed
// the thread, the nearest thread within reach lay behind, toward the tail: a bite's entry stuck at
// the thread's start, never drawn through, until the needle dragged it. (Bounds of the straight
// way between any two neighbours, tried, held points at s not yet caught up with the needle's
// passage and broke the bites.)
float2 span_bounds(Arc a, uint record, float3 x) {
  const float needle_length = a.radius * a.angle;
  uint j = 0;
  while (j < string_count && string_records[j] != record) ++j;
  const float lo = j == 0 || j == string_count ? needle_length + max(distance(tail_of(a), x), 1e-5)
                                               : punctures[string_records[j - 1]].place.z;
  float hi = path_length(a);
  if (j + 1 < string_count) hi = min(hi, punctures[string_records[j + 1]].place.z);
  hi = max(hi, needle_length + 1e-5);  // on the thread whatever the tissue did
  return float2(min(lo, hi), hi);
}

// Once the knot has caught, the thread from the needle's tail (driven) through the punctured
// points to the knot (the last) is a taut string: span j, from point j - 1 (the tail before the
// first) to point j, holds the thread between their s, l_j = s_j - s_j-1, and where it runs
// straight farther than that it bears the tension T_j of its stretch (STRING_GRIP above). The
// thread slides through a puncture (s_j moves, giving one span's thread to the other) only where
// its two sides' tensions break the capstan law, T_high <= T_low exp(mu theta) + mu N (theta the
// string's turn there, N the squeeze; mu and N 0 without friction on the thread, so the tensions
// are the same all along): by as much as brings them to the limit, in one sweep from the tail so
// that a pull reaches the knot in an iteration. Each tissue point is then pulled toward its
// neighbours by its spans' tensions (the force T_j u_back + T_j+1 u_fwd, as a spring toward
// there), so that a stitch pulled tight draws the tissue it passes toward its line and closes a
// wound. The tail bears T_0 along the first span (particles.needle_threads, particle_needle_load).
void taut_string(NeedleModel n, Arc a, uint needle) {
  const float3 tail = tail_of(a);
  const float needle_length = a.radius * a.angle;
  const float mu = n.puncture.y > 0 ? n.arc.w : 0.0, held = mu * n.puncture.y;
  const float3 way = string_count > 0 ? normalize(string_points[0] - tail + 1e-12) : float3(0, 0, 0);
  // per point: s, the span to it, the unit vectors toward its neighbours and the string's turn
  // there as the capstan factor (the points stay put through the pass: taken once)
  float s[MAX_STRING], d[MAX_STRING], E[MAX_STRING];
  float3 back[MAX_STRING], fwd[MAX_STRING];
  for (uint j = 0; j < string_count; ++j) {
    const float3 before = j > 0 ? string_points[j - 1] : tail;
    s[j] = punctures[string_records[j]].place.z;
    d[j] = distance(before, string_points[j]);
    back[j] = normalize(before - string_points[j] + 1e-12);
    fwd[j] = j + 1 < string_count ? normalize(string_points[j + 1] - string_points[j] + 1e-12) : float3(0, 0, 0);
    E[j] = exp(mu * acos(clamp(-dot(back[j], fwd[j]), -1.0, 1.0)));
  }
  // span j's stretch for its end at s_j (and its start at s_j-1), and its stiffness
#define SPAN_STRETCH(j) (d[j] - (s[j] - ((j) > 0 ? s[(j) - 1] : needle_length)))
#define SPAN_K(j) (((j) == 0 ? 1.0 : 0.5) * STRING_GRIP)
  // sweeps from the tail and back, as many as the string has points: a pull reaches the knot in an
  // iteration, and a loose loop anywhere along the string is drawn through at the friction's
  // tension (one sweep a iteration drew it as through a dashpot: 15 mN at the demo's 12 mm/s)
  for (uint sweep = 0; sweep < string_count; ++sweep)
  for (uint i = 0; i + 1 < string_count; ++i) {
    const uint j = (sweep & 1) != 0 ? string_count - 2 - i : i;
    if (punctures[string_records[j]].ids.w != 0) continue;  // a knot caught here holds
    const float Ka = SPAN_K(j), Kb = SPAN_K(j + 1), ea = SPAN_STRETCH(j), eb = SPAN_STRETCH(j + 1);
    // by: toward the knot (more thread on the tail's side); a slack side takes up its slack first,
    // so a loose loop is drawn through at the friction's tension, not at one the slip's rate sets
    float by = 0;
    if (Ka * max(ea, 0.0) > E[j] * Kb * max(eb, 0.0) + held) {
      by = ea - held / Ka;  // the far side stays slack
      if (eb + by > 0) by = (Ka * ea - E[j] * Kb * eb - held) / (Ka + E[j] * Kb);
    } else if (Kb * max(eb, 0.0) > E[j] * Ka * max(ea, 0.0) + held) {
      by = -(eb - held / Kb);
      if (ea - by > 0) by = -(Kb * eb - E[j] * Ka * ea - held) / (Kb + E[j] * Ka);
    }
    const float lo = j > 0 ? s[j - 1] : needle_length + 1e-5;
    s[j] = clamp(s[j] + by, min(lo, s[j]), max(s[j + 1] - 1e-5, s[j]));
  }
  float T_first = 0;
  for (uint j = 0; j < string_count; ++j) {
    Puncture p = punctures[string_records[j]];
    const float Ta = SPAN_K(j) * max(SPAN_STRETCH(j), 0.0);
    const float Tb = j + 1 < string_count ? SPAN_K(j + 1) * max(SPAN_STRETCH(j + 1), 0.0) : 0.0;
    if (j == 0) T_first = Ta;
    const float3 pull = Ta * back[j] + Tb * fwd[j];  // the thread's on the tissue
    pin(corners(p.ids.y), weights(p), string_points[j], string_points[j] + pull / STRING_GRIP, STRING_GRIP);
    p.place.z = s[j];
    // reported as the force the puncture puts on the thread, and its part along it (toward the knot)
    p.impulse = float4(-pull, Ta - Tb) * (pc.gravity.w * pc.gravity.w);
    punctures[string_records[j]] = p;
  }
#undef SPAN_STRETCH
#undef SPAN_K
  needle_threads[needle] = float4(T_first, way);
}

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  if (id.x >= pc.item_count) return;
  const NeedleModel n = needles[id.x];
  const bool free_ = bodies[n.ids.x].inv_inertia.w > 0;  // dynamic: let go of
  Arc a = arc_of(n);
  float3 tip = tip_of(a);
  if (n.ids.y != CRESSIM_NONE) positions[n.ids.y].xyz = tail_of(a);
  const float mu = n.arc.w;
  load_thread(n, a);
  const float end = path_length(a);
  // this iteration's grip replaces the last one's; whether the knot has caught
  bool caught = false;
  for (uint r = n.records.x; r < n.records.x + n.records.y; ++r)
    if (punctures[r].ids.x != PUNCTURE_FREE) {
      const uint3 c = corners(punctures[r].ids.y);
      tet_pins[c.x] = tet_pins[c.y] = tet_pins[c.z] = float4(0, 0, 0, 0);
      caught = caught || punctures[r].ids.w != 0;
    }
  load_string(n, a);
  if (caught) taut_string(n, a, id.x);  // sets the string's s, pins its tissue
  else if (n.puncture.y == 0) slide_string(a);  // friction on the thread (squeeze) holds s itself
  for (uint r = n.records.x; r < n.records.x + n.records.y; ++r) {
    Puncture p = punctures[r];
    if (p.ids.x == PUNCTURE_FREE) continue;
    const uint3 c = corners(p.ids.y);
    const float3 b = weights(p);
    const float3 x = surface_point(c, b);
    if (p.ids.x == PUNCTURE_INDENTING) {
      // the push counts along the normal toward the side the tip came from
      const float3 x0 = positions[c.x].xyz;
      float3 normal = normalize(cross(positions[c.y].xyz - x0, positions[c.z].xyz - x0));
      if (p.ids.z == 0) normal = -normal;
      const float depth = dot(x - tip, normal);
      // the last iteration's: the first of a substep also holds the tip's move over it
      p.place.w = PUNCTURE_GRIP * max(depth, 0.0);
      if (depth > 0 && free_) {
        share(n, c, b, x, tip);
        a = arc_of(n);
        tip = tip_of(a);
      } else if (depth > 0) {
        pin(c, b, x, tip);  // behind the surface point the tip does not pull it
      }
      punctures[r] = p;
      continue;
    }
    const float needle_length = a.radius * a.angle;
    if (p.place.z <= needle_length || thread_count < 2) {
      // where the path passes nearest, and how far along it from s
      const float nearest = min(nearest_s(n, a, x, p.place.z, REACH), end);
      const PathPoint q = path_at(n, a, nearest);
      if (q.segment == CRESSIM_NONE) {  // on the rigid, driven needle: the tissue goes to the path
        const float across = distance(x, q.x), slide = nearest - p.place.z;
        if (abs(slide) > mu * across) p.place.z += sign(slide) * (abs(slide) - mu * across);
        if (free_) {
          share(n, c, b, x, path_at(n, a, p.place.z).x);
          a = arc_of(n);
          tip = tip_of(a);
        } else {
          pin(c, b, x, path_at(n, a, p.place.z).x);
        }
        punctures[r] = p;
        continue;
      }
      p.place.z = nearest;  // the tail has passed: on the thread from here
      p.impulse = float4(0, 0, 0, 0);
    }
    if (p.ids.w != 0 || (!caught && p.place.z >= end - 1e-6)) {
      // the knot does not pass (nor come back out): it sits on the tissue, an anchor to the
      // thread's own solves (driven, as the tail is; an env reset gives it its mass back); the
      // tissue bears the thread's pull on it (taut_string, from the next iteration)
      p.place.z = end;
      p.ids.w = 1;
      caught = true;
      positions[n.ids.y + thread_count - 1] = float4(x, 0);
    } else if (caught) {  // the taut string set s: the thread is drawn through there
      const float4 reported = p.impulse;
      slide_through(n, a, p, x, p.place.zz);
      p.impulse = reported;
    } else if (n.puncture.y > 0) {  // squeeze > 0: friction on the thread
      thread_through(n, a, p, x, mu);
    } else {
      slide_through(n, a, p, x, span_bounds(a, r, x));
    }
    punctures[r] = p;
  }
  if (!caught) needle_threads[id.x] = float4(0, 0, 0, 0);
}
