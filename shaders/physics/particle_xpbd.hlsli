// One XPBD step of a constraint (Macklin et al. 2016); expects `pc` (ParticleConstants).

// the multiplier change of a constraint with value C, gradients g[k] and inverse masses w[k] of
// its n particles and multiplier `lambda` so far; the caller moves particle k by w[k] * dl * g[k]
// and adds dl to the multiplier
float xpbd_delta(ParticleConstraint rec, uint n, float C, float3 g[4], float w[4], float lambda) {
  const float alpha = rec.params.y / (pc.gravity.w * pc.gravity.w);
  float denom = alpha;
  for (uint k = 0; k < n; ++k) denom += w[k] * dot(g[k], g[k]);
  return denom <= 1e-20 ? 0 : (-C - alpha * lambda) / denom;
}
