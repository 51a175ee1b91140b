// Tetrahedron volume constraints: C = V / V0 - 1 (V0 > 0, vertices ordered positively).
#include "particle_constraint.hlsli"

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint c = constraint_index(id.x);
  if (c == CRESSIM_NONE) return;
  const ParticleConstraint rec = constraints[c];
  const float3 x0 = positions[rec.particles.x].xyz, e1 = positions[rec.particles.y].xyz - x0,
               e2 = positions[rec.particles.z].xyz - x0, e3 = positions[rec.particles.w].xyz - x0;
  const float v0 = rec.params.x;
  const float volume = dot(e1, cross(e2, e3)) / 6;
  float3 g[4];
  g[1] = cross(e2, e3) / (6 * v0);
  g[2] = cross(e3, e1) / (6 * v0);
  g[3] = cross(e1, e2) / (6 * v0);
  g[0] = -(g[1] + g[2] + g[3]);
  project(c, rec, 4, volume / v0 - 1, g);
}
