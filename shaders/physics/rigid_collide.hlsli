// Narrow phase: contacts between collider shapes, written to the env's contact slice.
// Every test reduces to spheres (a point with a radius) against a shape, except capsule pairs,
// which meet at the closest points of their segments, and box pairs: the face axis of least
// overlap (separating-axis test over the six face normals) gives the normal, and each box's
// corners inside the other give the points. Edge-edge contacts are not generated.

struct ShapePose {
  float3 p;
  float4 q;
};

ShapePose shape_pose(ColliderModel c) {
  ShapePose s;
  const uint b = c.ids.x;
  s.q = quat_mul(body_rotation(b), c.rotation);
  s.p = to_world(b, c.position.xyz);
  return s;
}

struct ContactSink {
  uint base;   // first contact slot of the env
  uint count;  // contacts so far
  float deepest;
};

void add_contact(inout ContactSink sink, uint a, uint b, float3 n, float3 pa, float3 pb, float depth,
                 float4 material) {
  sink.deepest = max(sink.deepest, depth);
  if (sink.count >= pc.max_contacts) return;
  Contact c;
  c.normal = float4(n, 0);
  c.anchor_a = float4(a == CRESSIM_NONE ? pa : quat_unrotate(rotations[a], pa - positions[a].xyz), 0);
  c.anchor_b = float4(b == CRESSIM_NONE ? pb : quat_unrotate(rotations[b], pb - positions[b].xyz), 0);
  // normal speed before the solve, for restitution; tangential speed picks static or dynamic
  // friction (above the rest speed: sliding)
  const float3 v = point_velocity(a, pa - body_position(a)) - point_velocity(b, pb - body_position(b));
  c.anchor_b.w = dot(n, v);
  c.friction = float4(0, 0, 0, 0);
  c.material = material;
  c.material.w = length(v - c.anchor_b.w * n) > rest_speed() ? material.y : material.x;
  c.bodies = uint4(a, b, 0, 0);
  contacts[sink.base + sink.count] = c;
  sink.count += 1;
}

// friction combines as the geometric mean, restitution as the larger
float4 pair_material(ColliderModel ca, ColliderModel cb) {
  return float4(sqrt(ca.material.x * cb.material.x), sqrt(ca.material.y * cb.material.y),
                max(ca.material.z, cb.material.z), 0);
}

float3 closest_on_segment(float3 p, float3 s0, float3 s1) {
  const float3 d = s1 - s0;
  const float t = saturate(dot(p - s0, d) / max(dot(d, d), 1e-12));
  return s0 + t * d;
}

// sphere (center x, radius r) owned by body a against shape cb of body b
void sphere_vs_shape(inout ContactSink sink, uint a, float3 x, float r, ColliderModel cb, float4 material) {
  const uint b = cb.ids.x, kind = cb.ids.y;
  const ShapePose s = shape_pose(cb);
  if (kind == SHAPE_PLANE) {
    const float3 n = quat_rotate(s.q, float3(0, 0, 1));
    const float dist = dot(x - s.p, n) - r;
    if (dist < 0) add_contact(sink, a, b, n, x - r * n, x - (r + dist) * n, -dist, material);
    return;
  }
  float3 center = s.p, surface_normal;
  float radius_b = 0;
  if (kind == SHAPE_SPHERE) radius_b = cb.size.x;
  if (kind == SHAPE_CAPSULE) {
    const float3 axis = quat_rotate(s.q, float3(0, 0, cb.size.y));
    center = closest_on_segment(x, s.p - axis, s.p + axis);
    radius_b = cb.size.x;
  }
  if (kind == SHAPE_SPHERE || kind == SHAPE_CAPSULE) {
    const float3 d = x - center;
    const float dist = length(d);
    if (dist >= r + radius_b) return;
    const float3 n = dist > 1e-9 ? d / dist : float3(0, 0, 1);
    add_contact(sink, a, b, n, x - r * n, center + radius_b * n, r + radius_b - dist, material);
    return;
  }
  // box: outside, the nearest surface point; inside, the face of least penetration
  const float3 he = cb.size.xyz;
  const float3 local = quat_unrotate(s.q, x - s.p);
  const float3 clamped = clamp(local, -he, he);
  const float3 d = local - clamped;
  const float dist = length(d);
  if (dist > 1e-9) {
    if (dist >= r) return;
    const float3 n = quat_rotate(s.q, d / dist);
    add_contact(sink, a, b, n, x - r * n, s.p + quat_rotate(s.q, clamped), r - dist, material);
    return;
  }
  const float3 pen = he - abs(local);
  uint axis_index = 0;
  if (pen.y < pen.x) axis_index = 1;
  if (pen.z < pen[axis_index]) axis_index = 2;
  float3 ln = float3(0, 0, 0);
  ln[axis_index] = local[axis_index] >= 0 ? 1 : -1;
  float3 on_face = local;
  on_face[axis_index] = ln[axis_index] * he[axis_index];
  const float3 n = quat_rotate(s.q, ln);
  add_contact(sink, a, b, n, x - r * n, s.p + quat_rotate(s.q, on_face), pen[axis_index] + r, material);
}

// closest points of segments p0p1 and q0q1 (clamped)
void closest_between_segments(float3 p0, float3 p1, float3 q0, float3 q1, out float3 cp, out float3 cq) {
  const float3 d1 = p1 - p0, d2 = q1 - q0, r = p0 - q0;
  const float a = dot(d1, d1), e = dot(d2, d2), f = dot(d2, r);
  float s = 0, t = 0;
  if (a <= 1e-12 && e <= 1e-12) {
  } else if (a <= 1e-12) {
    t = saturate(f / e);
  } else {
    const float c = dot(d1, r);
    if (e <= 1e-12) {
      s = saturate(-c / a);
    } else {
      const float b = dot(d1, d2), denom = a * e - b * b;
      s = denom > 1e-12 ? saturate((b * f - c * e) / denom) : 0;
      t = (b * s + f) / e;
      if (t < 0) { t = 0; s = saturate(-c / a); }
      else if (t > 1) { t = 1; s = saturate((b - c) / a); }
    }
  }
  cp = p0 + s * d1;
  cq = q0 + t * d2;
}

// shape ca (owner a) against shape cb (owner b): cb is a plane when ca is a box
void collide_ordered(inout ContactSink sink, ColliderModel ca, ColliderModel cb) {
  const uint a = ca.ids.x, kind_a = ca.ids.y, kind_b = cb.ids.y;
  const float4 material = pair_material(ca, cb);
  const ShapePose s = shape_pose(ca);
  if (kind_a == SHAPE_SPHERE) {
    sphere_vs_shape(sink, a, s.p, ca.size.x, cb, material);
  } else if (kind_a == SHAPE_CAPSULE) {
    const float3 axis = quat_rotate(s.q, float3(0, 0, ca.size.y));
    const float3 e0 = s.p - axis, e1 = s.p + axis;
    if (kind_b == SHAPE_CAPSULE) {
      const ShapePose t = shape_pose(cb);
      const float3 axis_b = quat_rotate(t.q, float3(0, 0, cb.size.y));
      float3 cp, cq;
      closest_between_segments(e0, e1, t.p - axis_b, t.p + axis_b, cp, cq);
      const float3 d = cp - cq;
      const float dist = length(d), reach = ca.size.x + cb.size.x;
      if (dist < reach) {
        const float3 n = dist > 1e-9 ? d / dist : float3(0, 0, 1);
        add_contact(sink, a, cb.ids.x, n, cp - ca.size.x * n, cq + cb.size.x * n, reach - dist, material);
      }
      return;
    }
    sphere_vs_shape(sink, a, e0, ca.size.x, cb, material);
    sphere_vs_shape(sink, a, e1, ca.size.x, cb, material);
    if (kind_b == SHAPE_BOX) {  // the middle of a long capsule lying on a box
      const ShapePose t = shape_pose(cb);
      sphere_vs_shape(sink, a, closest_on_segment(t.p, e0, e1), ca.size.x, cb, material);
    }
  } else if (kind_a == SHAPE_BOX) {
    for (uint i = 0; i < 8; ++i) {
      const float3 corner = float3((i & 1) ? 1 : -1, (i & 2) ? 1 : -1, (i & 4) ? 1 : -1) * ca.size.xyz;
      sphere_vs_shape(sink, a, s.p + quat_rotate(s.q, corner), 0, cb, material);
    }
  }
}

// corners of box ca (owner of the contact) lying in box cb, pushed out along n (from b to a)
void box_corners_in_box(inout ContactSink sink, ColliderModel ca, ShapePose sa, ColliderModel cb, ShapePose sb,
                        float3 n, float4 material) {
  const float3 hb = cb.size.xyz;
  // b's supporting plane along n: its face (or edge) facing a
  const float reach = abs(dot(quat_rotate(sb.q, float3(hb.x, 0, 0)), n)) +
                      abs(dot(quat_rotate(sb.q, float3(0, hb.y, 0)), n)) +
                      abs(dot(quat_rotate(sb.q, float3(0, 0, hb.z)), n));
  const float plane = dot(sb.p, n) + reach;
  for (uint i = 0; i < 8; ++i) {
    const float3 corner = sa.p + quat_rotate(sa.q, float3((i & 1) ? 1 : -1, (i & 2) ? 1 : -1, (i & 4) ? 1 : -1) * ca.size.xyz);
    const float3 local = quat_unrotate(sb.q, corner - sb.p);
    if (any(abs(local) > hb + 1e-4)) continue;
    const float depth = plane - dot(corner, n);
    if (depth > 0) add_contact(sink, ca.ids.x, cb.ids.x, n, corner, corner + depth * n, depth, material);
  }
}

void box_vs_box(inout ContactSink sink, ColliderModel c0, ColliderModel c1, float4 material) {
  const ShapePose s0 = shape_pose(c0), s1 = shape_pose(c1);
  const float3 d = s0.p - s1.p;
  float best = 3.4e38;
  float3 n = float3(0, 0, 1);
  for (uint k = 0; k < 6; ++k) {
    float3 e = float3(0, 0, 0);
    e[k % 3] = 1;
    const float3 axis = quat_rotate(k < 3 ? s0.q : s1.q, e);
    float r = 0;
    for (uint m = 0; m < 3; ++m) {
      float3 u = float3(0, 0, 0);
      u[m] = 1;
      r += abs(dot(quat_rotate(s0.q, u * c0.size.xyz), axis)) + abs(dot(quat_rotate(s1.q, u * c1.size.xyz), axis));
    }
    const float overlap = r - abs(dot(d, axis));
    if (overlap < 0) return;  // separated along this axis
    if (overlap < best) {
      best = overlap;
      n = dot(d, axis) >= 0 ? axis : -axis;
    }
  }
  // one box's corners usually make the face contact; the other's fill in where they do not
  // (duplicates would only dilute each contact's share of the simultaneous solve)
  const uint before = sink.count;
  box_corners_in_box(sink, c0, s0, c1, s1, n, material);
  if (sink.count - before < 4) box_corners_in_box(sink, c1, s1, c0, s0, -n, material);
}

// orders a pair so that collide_ordered sees it in a form it handles
void collide(inout ContactSink sink, ColliderModel c0, ColliderModel c1) {
  const uint k0 = c0.ids.y, k1 = c1.ids.y;
  if (k0 == SHAPE_PLANE && k1 == SHAPE_PLANE) return;
  if (k0 == SHAPE_PLANE) { collide_ordered(sink, c1, c0); return; }
  if (k1 == SHAPE_PLANE) { collide_ordered(sink, c0, c1); return; }
  if (k0 == SHAPE_BOX && k1 == SHAPE_BOX) {
    box_vs_box(sink, c0, c1, pair_material(c0, c1));
    return;
  }
  // spheres and capsules own the test against boxes; capsules against spheres
  if (k0 == SHAPE_BOX || (k0 == SHAPE_CAPSULE && k1 == SHAPE_SPHERE)) collide_ordered(sink, c1, c0);
  else collide_ordered(sink, c0, c1);
}
