// The colliders near a particle of phase ph at x this substep, as particle_collider_near.comp.hlsl
// says (bit b: its env's collider b, of the first 32; none for an inactive particle). Expects
// `objects`, particle_collide.hlsli and particle_fluid.hlsli.
uint colliders_near(uint4 ph, float3 x) {
  uint near = 0;
  if ((ph.w & PARTICLE_ACTIVE) == 0) return near;
  const float r = objects[ph.y].material.x;
  const float reach = (ph.x == PARTICLE_FLUID ? wall_reach(make_kernel(r), r) : r) + pc.grid.x;
  const EnvRigidRange range = env_rigid_ranges[ph.z];
  const uint first = range.bodies.z, end = first + min(range.bodies.w, 32u);
  for (uint c = first; c < end; ++c) {
    const ColliderModel cm = colliders[c];
    float3 n;
    float depth;
    if (meets_particles(cm) && sphere_penetration(x, reach, cm, collider_pose(cm), n, depth)) near |= 1u << (c - first);
  }
  return near;
}
