// Strand stretch-shear (Kugelstadt & Schoemer 2016), solved along each strand at once: record i
// makes segment x_i -> x_i+1 equal its frame's z axis over the rest length,
// C_i = x_i+1 - x_i - l_i q_i e3 q_i* = 0 (a vector; in length units). Neighbouring records share a
// particle, so one XPBD step of a whole strand is block tridiagonal with the same scalar for all
// three components (the frame's share taken isotropic, 4 w_q l^2, as Kugelstadt & Schoemer do):
//   (w_i + w_i+1 + 4 w_q,i l_i^2) dl_i - w_i dl_i-1 - w_i+1 dl_i+1 = -C_i
// solved directly (Thomas) by one thread per strand; particle j moves by w_j (dl_j-1 - dl_j) and
// frame i turns toward its segment by its share of -dl_i. Why: projected colour by colour, a turn
// at one end reached the far end one segment per iteration, and a rod bent by a tendon settled
// where the iterations ran out (a 20-segment rod turned 1.49 times as far as its tendon allows at
// 4 iterations, 1.18 at 64); solved along the strand the frames and segments agree after every
// step. A particle held rigidly by an attachment is an anchor (weight 0); a cut record drops out.
#include "particle_constraint.hlsli"
#include "particle_anchors.hlsli"
#include "cressim/quat.h"

RWStructuredBuffer<float4> orientations;
StructuredBuffer<float> orientation_weights;
StructuredBuffer<uint2> chains;            // (first record, count)
RWStructuredBuffer<float4> chain_scratch;  // per record: (d' xyz, c'), then (dl xyz, on)

// the diagonal's particle part is scaled by 1 + REGULARISATION, as the stretch chain's (a frame
// anchored between two fixed particles leaves a row with no weight otherwise)
static const float REGULARISATION = 1e-3;

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  if (id.x >= pc.item_count) return;
  const uint2 chain = chains[id.x];
  find_anchors(constraints[chain.x].particles.x);
  // forward elimination: row i couples to row i-1 through their shared particle x_i
  float prev_m = 1;
  float3 prev_d = float3(0, 0, 0);
  bool prev_on = false;
  for (uint i = 0; i < chain.y; ++i) {
    const uint c = chain.x + i;
    const ParticleConstraint rec = constraints[c];
    const float4 x0 = positions[rec.particles.x], x1 = positions[rec.particles.y];
    const float w0 = weight(rec.particles.x, x0.w), w1 = weight(rec.particles.y, x1.w);
    const uint e = rec.particles.z - pc.particle_count;
    const float l = rec.params.x;
    const float3 C = x1.xyz - x0.xyz - l * quat_rotate(orientations[e], float3(0, 0, 1));
    const float diag = (1 + REGULARISATION) * (w0 + w1) + 4 * orientation_weights[e] * l * l;
    const bool on = cut[c] == 0 && diag > 1e-20;
    float m = 1;
    float3 dp = float3(0, 0, 0);
    if (on) {
      const float lower = prev_on ? -w0 : 0;
      m = diag - lower * lower / prev_m;
      dp = (-C - lower * prev_d) / m;
      if (i > 0) chain_scratch[2 * (c - 1)].w = lower / prev_m;
    }
    chain_scratch[2 * c] = float4(dp, 0);
    chain_scratch[2 * c + 1] = float4(0, 0, 0, on ? 1 : 0);
    prev_m = m;
    prev_d = dp;
    prev_on = on;
  }
  // back substitution: dl_i = d'_i - c'_i dl_i+1
  float3 next_dl = float3(0, 0, 0);
  for (uint k = chain.y; k-- > 0;) {
    const uint c = chain.x + k;
    const float4 s = chain_scratch[2 * c];
    const float3 dl = chain_scratch[2 * c + 1].w > 0 ? s.xyz - s.w * next_dl : float3(0, 0, 0);
    chain_scratch[2 * c + 1].xyz = dl;
    next_dl = dl;
  }
  // apply: particle j is record j's first (-dl_j) and record j-1's second (+dl_j-1); frame i turns
  // by its share of gamma_i = -dl_i, q += 2 w_q l gamma q e3* (Kugelstadt & Schoemer's update)
  float3 from_prev = float3(0, 0, 0);
  for (uint j = 0; j <= chain.y; ++j) {
    const uint c = chain.x + min(j, chain.y - 1);
    const ParticleConstraint rec = constraints[c];
    const uint p = j < chain.y ? rec.particles.x : rec.particles.y;
    float3 dl = float3(0, 0, 0);
    if (j < chain.y) {
      dl = chain_scratch[2 * c + 1].xyz;
      const uint e = rec.particles.z - pc.particle_count;
      const float4 q = orientations[e];
      const float wq = orientation_weights[e];
      // q e3* = (-q.y, q.x, -q.w, q.z) as xyzw
      const float4 dq = 2 * wq * rec.params.x * quat_mul(float4(-dl, 0), float4(-q.y, q.x, -q.w, q.z));
      orientations[e] = normalize(q + dq);
    }
    const float4 x = positions[p];
    const float w = weight(p, x.w);
    if (w > 0) positions[p].xyz = x.xyz + w * (from_prev - dl);
    from_prev = dl;
  }
}
