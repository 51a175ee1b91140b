// Distance constraints (tet edges, meshfree neighbours, strand segments): C = |xi - xj| / L - 1.
// (the family's passes: particle_distance.comp.hlsl; with the others in one workgroup: particle_iterations)
uint evaluate_distance(ParticleConstraint rec, float3 x[4], out float C, out float3 g[4]) {
  const float3 d = x[0] - x[1];
  const float len = length(d), rest = rec.params.x;
  g[0] = float3(0, 0, 0);
  g[1] = g[2] = g[3] = g[0];
  if (len > 1e-9) {
    g[0] = d / (len * rest);
    g[1] = -g[0];
  }
  C = len / rest - 1;
  return 2;
}
