// A fluid particle's SPH density and its constraint's multiplier (particle_fluid_lambda.comp.hlsl
// says what they are), with the walls' density gradient that its correction takes. Used by
// particle_fluid_lambda and particle_fluid_iterations. Expects `objects`, particle_neighbor_list,
// particle_fluid and particle_fluid_boundary included.
float fluid_multiplier(uint i, uint4 ph, float4 xi, out float density, out float3 wall_gradient) {
  const ParticleObject o = objects[ph.y];
  const Kernel K = make_kernel(o.material.x);
  const float rho0 = o.material.w;
  float sum_squares = 0;
  float3 grad_i;
  fluid_boundary(i, xi.xyz, ph.z, o.material.x, particle_mass(xi), K, density, grad_i);
  wall_gradient = grad_i;
  grad_i /= rho0;
  FOR_EACH_NEIGHBOR(i, j, xj, j_fluid, 1, {
    if (j_fluid) {
      const float3 r = xi.xyz - xj.xyz;
      const float m = particle_mass(xj);
      density += m * spiky(K, dot(r, r));
      if (j != i) {
        const float3 g = (m / rho0) * spiky_gradient(K, r);
        grad_i += g;
        sum_squares += dot(g, g);
      }
    }
  })
  const float C = max(density / rho0 - 1, 0.0);
  return C > 0 ? -C / (sum_squares + dot(grad_i, grad_i) + 1e-6) : 0;
}
