// The density that rigid walls add to a fluid particle near them. Without it a particle at a wall
// misses the neighbours the wall stands in for, reads below rest density and is compressed until
// it does not (a settled column sat 9 % below its authored height). Each collider shape within
// reach counts as the fluid's rest lattice continued beyond its surface (a half-space, like the
// boundary particles of Akinci et al. 2012 at the fluid's own spacing): the lattice layers at
// depths d + r + 2 r k behind it, each the nine lattice sites under the particle that fall inside
// the kernel. A particle touching a flat wall (d = r) on the rest lattice then reads exactly the
// rest density; corners count the overlap of two walls twice (a few per cent, at the corner only).
// Expects particle_fluid.hlsli, particle_collide.hlsli and its buffers, and collider_near.

// density of the lattice behind a wall at distance d (centre to surface) and its derivative
// along the wall normal, taken with the spiky gradient as the fluid's own corrections are
void wall_layers(Kernel K, float r, float m, float d, out float density, out float slope) {
  density = 0;
  slope = 0;
  for (uint k = 0; k < 2; ++k) {
    const float z = d + r + 2 * r * k;
    for (uint q = 0; q < 3; ++q) {  // in-plane offsets of squared length 0, 4 r^2 (4 of them), 8 r^2 (4)
      const float sites = q == 0 ? 1 : 4, R2 = z * z + 4 * r * r * q;
      if (R2 >= K.h2) continue;
      const float R = sqrt(R2);
      density += sites * m * spiky(K, R2);
      slope += sites * m * K.spiky * (K.h - R) * (K.h - R) * z / R;
    }
  }
}

// every collider near particle i within the kernel's reach: density and its gradient at x
void fluid_boundary(uint i, float3 x, uint env, float r, float m, Kernel K, out float density, out float3 gradient) {
  density = 0;
  gradient = float3(0, 0, 0);
  if (pc.has_rigid == 0) return;
  const float reach = wall_reach(K, r);
  FOR_EACH_NEAR_COLLIDER(i, env, cm, {
    float3 n;
    float depth, rho, slope;
    if (!sphere_penetration(x, reach, cm, collider_pose(cm), n, depth)) continue;
    wall_layers(K, r, m, max(reach - depth, 0.0), rho, slope);
    density += rho;
    gradient += slope * n;
  })
}
