// Tetrahedron volume constraints: C = V / V0 - 1 (V0 > 0, vertices ordered positively).
// (the family's passes: particle_volume.comp.hlsl; with the others in one workgroup: particle_iterations)
uint evaluate_volume(ParticleConstraint rec, float3 x[4], out float C, out float3 g[4]) {
  const float3 e1 = x[1] - x[0], e2 = x[2] - x[0], e3 = x[3] - x[0];
  const float v0 = rec.params.x;
  g[1] = cross(e2, e3) / (6 * v0);
  g[2] = cross(e3, e1) / (6 * v0);
  g[3] = cross(e1, e2) / (6 * v0);
  g[0] = -(g[1] + g[2] + g[3]);
  C = dot(e1, cross(e2, e3)) / (6 * v0) - 1;
  return 4;
}
