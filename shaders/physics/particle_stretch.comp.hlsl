// Strand stretch, solved along each strand at once: record i keeps the segment between chain
// particles i and i+1 at its rest length, C_i = |x_i - x_{i+1}| / L_i - 1. Neighbouring records
// share a particle, so one XPBD step of the whole strand is a tridiagonal system
//   (w_i + w_{i+1}) / L_i^2 dl_i + a_i dl_i + A_{i,i-1} dl_{i-1} + A_{i,i+1} dl_{i+1} = -C_i - a_i lambda_i,
//   A_{i,i+1} = -w_{i+1} (n_i . n_{i+1}) / (L_i L_{i+1}),  n_i = (x_i - x_{i+1}) / |x_i - x_{i+1}|
// (a_i = compliance / h^2), solved directly (Thomas) by one thread per strand, then every particle
// moves by w_j (dl_j n_j / L_j - dl_{j-1} n_{j-1} / L_{j-1}). Why: projected colour by colour, a
// chain of n segments needs about n iterations to carry a correction from end to end, and at the
// default 4 substeps x 4 iterations a hanging thread stretched 3-7 % and a swinging one 18 %; the
// direct solve is a Newton step of the whole strand, so a few of them make it inextensible at
// any resolution. A particle held rigidly by an attachment is an anchor (weight 0), and a cut
// record drops out of its chain (its neighbours decouple).
#include "particle_constraint.hlsli"
#include "particle_anchors.hlsli"

StructuredBuffer<uint2> chains;            // (first record, count)
RWStructuredBuffer<float4> chain_scratch;  // per record: (n, 1 / L), then (d', c', on, dl)

// the diagonal is scaled by 1 + REGULARISATION: a straight strand pulled taut between two fixed
// ends has a singular system (its length along the line cannot change); the fixed point of the
// repeated solves is still C = 0
static const float REGULARISATION = 1e-3;

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  if (id.x >= pc.item_count) return;
  const uint2 chain = chains[id.x];
  find_anchors(constraints[chain.x].particles.x);
  const float h2 = pc.gravity.w * pc.gravity.w;
  // forward elimination; the coupling A_{i,i-1} is known at row i (it needs n_i), so row i also
  // writes row i-1's c' = A_{i-1,i} / m_{i-1}
  float3 prev_n = float3(0, 0, 0);
  float prev_inv_l = 0, prev_m = 1, prev_d = 0;
  bool prev_on = false;
  for (uint i = 0; i < chain.y; ++i) {
    const uint c = chain.x + i;
    const ParticleConstraint rec = constraints[c];
    const float4 x0 = positions[rec.particles.x], x1 = positions[rec.particles.y];
    const float w0 = weight(rec.particles.x, x0.w), w1 = weight(rec.particles.y, x1.w);
    const float3 d = x0.xyz - x1.xyz;
    const float len = length(d), inv_l = 1 / rec.params.x, alpha = rec.params.y / h2;
    const float3 n = len > 1e-9 ? d / len : float3(0, 0, 0);
    const float diag = (1 + REGULARISATION) * (w0 + w1) * inv_l * inv_l + alpha;
    const bool on = cut[c] == 0 && diag > 1e-20;
    float m = 1, dp = 0;
    if (on) {
      const float lower = prev_on ? -w0 * dot(prev_n, n) * prev_inv_l * inv_l : 0;
      m = diag - lower * lower / prev_m;
      dp = (-(len * inv_l - 1) - alpha * lambdas[c] - lower * prev_d) / m;
      if (i > 0) chain_scratch[2 * (c - 1) + 1].y = lower / prev_m;
    }
    chain_scratch[2 * c] = float4(n, inv_l);
    chain_scratch[2 * c + 1] = float4(dp, 0, on ? 1 : 0, 0);
    prev_n = n;
    prev_inv_l = inv_l;
    prev_m = m;
    prev_d = dp;
    prev_on = on;
  }
  // back substitution: dl_i = d'_i - c'_i dl_{i+1}
  float next_dl = 0;
  for (uint k = chain.y; k-- > 0;) {
    const uint c = chain.x + k;
    float4 s = chain_scratch[2 * c + 1];
    s.w = s.z > 0 ? s.x - s.y * next_dl : 0;
    chain_scratch[2 * c + 1] = s;
    lambdas[c] += s.w;
    next_dl = s.w;
  }
  // apply: particle j takes record j's push along n_j and record j-1's along -n_{j-1}
  float3 from_prev = float3(0, 0, 0);
  for (uint j = 0; j <= chain.y; ++j) {
    const uint c = chain.x + min(j, chain.y - 1);
    const ParticleConstraint rec = constraints[c];
    const uint p = j < chain.y ? rec.particles.x : rec.particles.y;
    float3 push = float3(0, 0, 0);
    if (j < chain.y) {
      const float4 g = chain_scratch[2 * c];
      push = chain_scratch[2 * c + 1].w * g.w * g.xyz;
    }
    const float4 x = positions[p];
    const float w = weight(p, x.w);
    if (w > 0) positions[p].xyz = x.xyz + w * (push - from_prev);
    from_prev = push;
  }
}
