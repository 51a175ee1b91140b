// Particle (a sphere of the object's radius) against rigid collider shapes: sphere, box,
// capsule, plane. Poses of moving bodies are taken along the frame: the rigid solver has
// already stepped the whole frame, so a body is placed back along its velocity by the part of
// the frame still to come (grid.y is the fraction done at the end of this substep).
// Expects `pc` declared by the including kernel; declares the read-only rigid state it reads.

StructuredBuffer<EnvRigidRange> env_rigid_ranges;
StructuredBuffer<ColliderModel> colliders;
StructuredBuffer<float4> body_positions;
StructuredBuffer<float4> body_rotations;
StructuredBuffer<float4> body_linear_velocities;
StructuredBuffer<float4> body_angular_velocities;

struct ColliderPose {
  float3 p;
  float4 q;
  float3 v;  // body velocity, for friction
  float3 w;
  float3 body_p;
};

ColliderPose collider_pose(ColliderModel c) {
  ColliderPose s;
  const uint b = c.ids.x;
  s.v = float3(0, 0, 0);
  s.w = float3(0, 0, 0);
  if (b == CRESSIM_NONE) {
    s.p = c.position.xyz;
    s.q = c.rotation;
    s.body_p = s.p;
    return s;
  }
  s.v = body_linear_velocities[b].xyz;
  s.w = body_angular_velocities[b].xyz;
  const float frame_left = pc.gravity.w * pc.grid.w * (1 - pc.grid.y);  // seconds of the frame still to come
  const float4 q = body_rotations[b];
  s.body_p = body_positions[b].xyz - s.v * frame_left;
  s.q = quat_mul(q, c.rotation);
  s.p = s.body_p + quat_rotate(q, c.position.xyz);
  return s;
}

// particles meet the collider (its group lacks COLLIDER_NO_PARTICLES)
bool meets_particles(ColliderModel c) { return (c.ids.z & COLLIDER_NO_PARTICLES) == 0; }

// visits the colliders cm of env `env` near particle i this substep (particle_collider_near;
// expects `collider_near` declared by the including kernel); `continue` in BODY goes to the next
#define FOR_EACH_NEAR_COLLIDER(i, env, cm, BODY)                                               \
  {                                                                                            \
    const EnvRigidRange range_ = env_rigid_ranges[env];                                        \
    const uint first_ = range_.bodies.z, end_ = first_ + range_.bodies.w;                      \
    uint near_ = collider_near[i], next_ = first_ + 32;                                        \
    while (true) {                                                                             \
      uint c_;                                                                                 \
      if (near_ != 0) {                                                                        \
        c_ = first_ + firstbitlow(near_);                                                      \
        near_ &= near_ - 1;                                                                    \
      } else if (next_ < end_) {                                                               \
        c_ = next_++;                                                                          \
      } else {                                                                                 \
        break;                                                                                 \
      }                                                                                        \
      const ColliderModel cm = colliders[c_];                                                  \
      if (!meets_particles(cm)) continue;                                                      \
      BODY                                                                                     \
    }                                                                                          \
  }

float3 closest_on_segment(float3 p, float3 s0, float3 s1) {
  const float3 d = s1 - s0;
  const float t = saturate(dot(p - s0, d) / max(dot(d, d), 1e-12));
  return s0 + t * d;
}

// depth > 0 when the sphere (x, r) overlaps the shape; n points out of the shape
bool sphere_penetration(float3 x, float r, ColliderModel c, ColliderPose s, out float3 n, out float depth) {
  const uint kind = c.ids.y;
  n = float3(0, 0, 1);
  depth = 0;
  if (kind == SHAPE_PLANE) {
    n = quat_rotate(s.q, float3(0, 0, 1));
    depth = r - dot(x - s.p, n);
    return depth > 0;
  }
  if (kind == SHAPE_SPHERE || kind == SHAPE_CAPSULE) {
    float3 center = s.p;
    if (kind == SHAPE_CAPSULE) {
      const float3 axis = quat_rotate(s.q, float3(0, 0, c.size.y));
      center = closest_on_segment(x, s.p - axis, s.p + axis);
    }
    const float3 d = x - center;
    const float len = length(d);
    depth = r + c.size.x - len;
    if (depth <= 0) return false;
    n = len > 1e-9 ? d / len : float3(0, 0, 1);
    return true;
  }
  if (kind == SHAPE_BOX) {
    const float3 he = c.size.xyz;
    const float3 local = quat_unrotate(s.q, x - s.p);
    const float3 clamped = clamp(local, -he, he);
    const float3 d = local - clamped;
    const float len = length(d);
    if (len > 1e-9) {
      depth = r - len;
      if (depth <= 0) return false;
      n = quat_rotate(s.q, d / len);
      return true;
    }
    const float3 pen = he - abs(local);
    uint a = 0;
    if (pen.y < pen.x) a = 1;
    if (pen.z < pen[a]) a = 2;
    float3 ln = float3(0, 0, 0);
    ln[a] = local[a] >= 0 ? 1 : -1;
    n = quat_rotate(s.q, ln);
    depth = pen[a] + r;
    return true;
  }
  return false;
}

// Coulomb friction between a particle object (material.y) and a collider (material.x)
float contact_friction(float object_friction, ColliderModel c) {
  return sqrt(object_friction * c.material.x);
}

// how far the collider's surface at x moves over a substep of h seconds (friction is slip against it)
float3 surface_motion(ColliderPose s, float3 x, float h) {
  return h * (s.v + cross(s.w, x - s.body_p));
}

