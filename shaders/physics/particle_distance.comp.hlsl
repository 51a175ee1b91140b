// Distance constraints (tet edges, meshfree neighbours, strand segments): C = |xi - xj| / L - 1.
#include "particle_constraint.hlsli"

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint c = constraint_index(id.x);
  if (c == CRESSIM_NONE) return;
  const ParticleConstraint rec = constraints[c];
  const float3 d = positions[rec.particles.x].xyz - positions[rec.particles.y].xyz;
  const float len = length(d), rest = rec.params.x;
  float3 g[4] = {float3(0, 0, 0), float3(0, 0, 0), float3(0, 0, 0), float3(0, 0, 0)};
  if (len > 1e-9) {
    g[0] = d / (len * rest);
    g[1] = -g[0];
  }
  project(c, rec, 2, len / rest - 1, g);
}
