// Particle i (phase ph) at x pushed out of the rigid colliders of its env near it, with friction,
// as particle_gather.comp.hlsl says; what it does to each body goes to rigid_pushes,
// rigid_contacts and rigid_forces. Expects those, `pc`, `objects`, `prev_positions`, `bodies`,
// `body_contact_counts` and `collider_near` declared, and particle_collide.hlsli included.
float4 collide_near_colliders(uint i, uint4 ph, float4 x) {
  const ParticleObject o = objects[ph.y];
  const float r = o.material.x, h = pc.gravity.w;
  const float3 x0 = prev_positions[i].xyz;
  rigid_pushes[i] = float4(0, 0, 0, 0);
  FOR_EACH_NEAR_COLLIDER(i, ph.z, cm, {
    const ColliderPose s = collider_pose(cm);
    float3 n;
    float depth;
    if (!sphere_penetration(x.xyz, r, cm, s, n, depth)) continue;
    const uint b = cm.ids.x;
    float share = 1, wb = 0;
    if (b != CRESSIM_NONE && bodies[b].inv_inertia.w > 0) {
      // the body's generalized inverse mass at the contact point, along n
      const float4 q = body_rotations[b];
      const float3 arm = x.xyz - r * n - s.body_p, rn = quat_unrotate(q, cross(arm, n));
      wb = (bodies[b].inv_inertia.w + dot(rn, bodies[b].inv_inertia.xyz * rn)) * max(body_contact_counts[b], 1u);
      share = x.w / (x.w + wb);
    }
    if (b != CRESSIM_NONE) rigid_contacts[i] = float4(x.xyz - r * n, 0);
    // friction: the particle's slip against the collider surface over this substep
    const float3 slip = (x.xyz + depth * n - x0) - surface_motion(s, x.xyz, h);
    const float3 tangential = slip - dot(slip, n) * n;
    const float t = length(tangential);
    const float mu = contact_friction(o.material.y, cm);
    const float3 correction = depth * n - (t > 1e-9 ? tangential * (t <= mu * depth ? 1.0 : min(mu * depth / t, 1.0)) : 0);
    x.xyz += share * correction;
    if (wb > 0) rigid_pushes[i] = float4(correction / (x.w + wb), float(b + 1));
    if (b != CRESSIM_NONE && x.w > 0) {
      // the momentum the particle loses and the body gains: the particle moves by share x
      // correction over the substep (m share correction / h = correction / ((w + wb) h)); a
      // dynamic body takes the opposite (particle_rigid_push), a kinematic one (wb 0) none
      const float3 momentum = correction / ((x.w + wb) * h);
      rigid_forces[i] = float4(rigid_forces[i].xyz - momentum / (h * pc.grid.w), float(b + 1));
    }
  })
  return x;
}
