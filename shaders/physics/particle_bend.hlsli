// Strand bending toward straight: the middle particle's distance from the midpoint of its two
// neighbours, per unit segment length: C = (|x1 - (x0 + x2) / 2| - rest) / segment, rest 0. For
// small angles this is the discrete curvature times segment / 2, so bend compliance acts like a
// rod's inverse bending stiffness.
// (the family's passes: particle_bend.comp.hlsl)
uint evaluate_bend(ParticleConstraint rec, float3 x[4], out float C, out float3 g[4]) {
  const float3 u = x[1] - 0.5 * (x[0] + x[2]);
  const float len = length(u), seg = rec.params.z;
  g[0] = float3(0, 0, 0);
  g[1] = g[2] = g[3] = g[0];
  C = 0;
  if (len > 1e-9) {
    g[1] = u / (len * seg);
    g[0] = -0.5 * g[1];
    g[2] = -0.5 * g[1];
    C = (len - rec.params.x) / seg;
  }
  return 3;
}
