// Strand bending toward straight: the middle particle's distance from the midpoint of its two
// neighbours, per unit segment length: C = (|x1 - (x0 + x2) / 2| - rest) / segment, rest 0. For small angles this is the discrete curvature
// times segment / 2, so bend compliance acts like a rod's inverse bending stiffness.
#include "particle_constraint.hlsli"

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint c = constraint_index(id.x);
  if (c == CRESSIM_NONE) return;
  const ParticleConstraint rec = constraints[c];
  const float3 u = positions[rec.particles.y].xyz - 0.5 * (positions[rec.particles.x].xyz + positions[rec.particles.z].xyz);
  const float len = length(u), seg = rec.params.z;
  float3 g[4] = {float3(0, 0, 0), float3(0, 0, 0), float3(0, 0, 0), float3(0, 0, 0)};
  float C = 0;
  if (len > 1e-9) {
    const float3 n = u / len;
    g[1] = n / seg;
    g[0] = -0.5 * g[1];
    g[2] = -0.5 * g[1];
    C = (len - rec.params.x) / seg;
  }
  project(c, rec, 3, C, g);
}
