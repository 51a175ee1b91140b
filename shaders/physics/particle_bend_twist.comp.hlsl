// Strand bend and twist (Kugelstadt & Schoemer 2016), solved along each strand at once. Record i
// pulls the Darboux vector Omega_i = q_i* q_{i+1} of neighbouring segment frames to its rest value
// (straight, untwisted: the identity), C_i = Im(Omega_i): x, y bending (compliance params.x), z
// twist (params.y). Its step on the two frames, with delta_i = -dlambda_i (a pure quaternion):
//   q_i += w_i q_{i+1} delta_i,  q_{i+1} -= w_{i+1} q_i delta_i  (applied below to first order).
// Neighbouring records share a frame, so the XPBD step of a whole chain is one linear system,
// tridiagonal and the same for each component (Deul et al. 2018 solve rods directly for this):
//   (w_i + w_{i+1} + a_i) dl_i - s w_i dl_{i-1} - s' w_{i+1} dl_{i+1} = -C_i - a_i lambda_i
// with a_i = compliance / h^2 and s, s' the signs of Omega_{i-1}.w Omega_i.w and Omega_i.w
// Omega_{i+1}.w (q and -q are the same frame). Solving it directly (Thomas) rather than record by
// record gives the compliance-weighted share: a cable turned at both held ends twists evenly,
// where colour-by-colour projection of stiff records leaves alternate pairs twisted and untwisted.
// One thread per chain (particles.bend_twist_chains); cut records drop out of their chain. A
// frame held rigidly by an attachment (hold_frame, compliance 0) is an anchor here (weight 0):
// the attachment pass puts it where its body says, and the chain's share is solved around it.
#include "particle_constraint.hlsli"
#include "cressim/quat.h"

RWStructuredBuffer<float4> orientations;
StructuredBuffer<float> orientation_weights;
StructuredBuffer<uint4> phases;
StructuredBuffer<uint> edge_particles;
StructuredBuffer<ParticleAttachment> attachments;
StructuredBuffer<uint2> chains;               // (first record, count)
RWStructuredBuffer<float4> chain_scratch;     // per record: (g bend, g twist, sign, on), then d' / dl

static const float COMPLIANCE_FLOOR = 1e-3;

// frames of one chain held rigidly by their env's attachment slots (the first few)
static const uint MAX_ANCHORS = 8;
static uint anchors[MAX_ANCHORS];
static uint anchor_count;

void find_anchors(uint first_frame) {
  anchor_count = 0;  // set here: initialisers of static globals are not run per invocation everywhere
  if (pc.has_rigid == 0 || pc.attachment_count == 0) return;
  const uint per_env = pc.attachment_count / pc.env_count;
  const uint env = phases[edge_particles[first_frame]].z;
  for (uint a = env * per_env; a < (env + 1) * per_env && anchor_count < MAX_ANCHORS; ++a) {
    const ParticleAttachment at = attachments[a];
    if (at.ids.z != ATTACH_FREE && at.hold.x != CRESSIM_NONE && at.local.w == 0) anchors[anchor_count++] = at.hold.x;
  }
}

float frame_weight(uint e) {
  for (uint k = 0; k < anchor_count; ++k)
    if (anchors[k] == e) return 0;
  return orientation_weights[e];
}

float4 darboux(uint c) {
  const ParticleConstraint rec = constraints[c];
  return quat_mul(quat_conj(orientations[rec.particles.x - pc.particle_count]),
                  orientations[rec.particles.y - pc.particle_count]);
}

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  if (id.x >= pc.item_count) return;
  const uint2 chain = chains[id.x];
  find_anchors(constraints[chain.x].particles.x - pc.particle_count);
  const float h2 = pc.gravity.w * pc.gravity.w;
  // forward elimination. Row i: D_i = w_i + w_{i+1} + a_i, its coupling to row i+1 is
  // U_i = u_i s_i s_{i+1} with u_i = -w_{i+1} (0 where either record is cut); the sign of the next
  // row is not known yet, so g_i = u_i s_i / m_i is kept and s_{i+1} applied when it is
  float2 prev_m = float2(1, 1);
  float prev_u = 0;  // u_{i-1} s_{i-1}, 0 when row i-1 is off
  float3 prev_d = float3(0, 0, 0);
  for (uint i = 0; i < chain.y; ++i) {
    const uint c = chain.x + i;
    const ParticleConstraint rec = constraints[c];
    const float4 omega = darboux(c);
    const float sign = omega.w < 0 ? -1 : 1;
    const float w0 = frame_weight(rec.particles.x - pc.particle_count);
    const float w1 = frame_weight(rec.particles.y - pc.particle_count);
    // a compliance floor of 1e-3 of the frames' weight: with both ends of a chain anchored its
    // system is singular without compliance (the total twist between anchors cannot change),
    // and a compliance far below the weights is lost to float rounding
    const float2 a = max(float2(rec.params.x, rec.params.y) / h2, COMPLIANCE_FLOOR * max(w0, w1));
    const float2 diag = (w0 + w1) + a;
    const bool on = cut[c] == 0 && min(diag.x, diag.y) > 1e-20;
    float2 g = float2(0, 0);
    float3 d = float3(0, 0, 0);
    if (on) {
      const float3 lambda = float3(lambdas[3 * c], lambdas[3 * c + 1], lambdas[3 * c + 2]);
      const float3 rhs = -omega.xyz - float3(a.x, a.x, a.y) * lambda;
      const float lower = prev_u * sign;  // L_i = U_{i-1}
      const float2 m = diag - lower * lower / prev_m;
      g = -w1 * sign / m;
      d = (rhs - lower * prev_d) / float3(m.x, m.x, m.y);
      prev_m = m;
    }
    chain_scratch[2 * c] = float4(g, sign, on ? 1 : 0);
    chain_scratch[2 * c + 1] = float4(d, 0);
    prev_u = on ? -w1 * sign : 0;
    prev_d = d;
  }
  // back substitution: dl_i = d'_i - g_i s_{i+1} dl_{i+1} (stored in place of d')
  float3 next_dl = float3(0, 0, 0);
  float next_sign = 1;
  for (uint k = chain.y; k-- > 0;) {
    const uint c = chain.x + k;
    const float4 gs = chain_scratch[2 * c];
    const float3 dl = chain_scratch[2 * c + 1].xyz - float3(gs.x, gs.x, gs.y) * next_sign * next_dl;
    chain_scratch[2 * c + 1] = float4(dl, 0);
    next_dl = dl;  // 0 on a cut row, which decouples its neighbours
    next_sign = gs.z;
  }
  // apply: frame j turns by record j-1 (as its second frame) and record j (as its first), both
  // taken in its own frame (q_{j+1} = s_j q_j to first order): q_j += w_j q_j (s_j d_j - s_{j-1} d_{j-1})
  // with d = -dl. Turning q_j itself, not its neighbours, keeps the part of dl that no frame can
  // follow (the even share between two anchored frames) from turning into a spurious rotation.
  float3 turn_prev = float3(0, 0, 0);  // s_{j-1} d_{j-1}
  for (uint j = 0; j <= chain.y; ++j) {
    const uint c = chain.x + min(j, chain.y - 1);
    const ParticleConstraint rec = constraints[c];
    const uint e = j < chain.y ? rec.particles.x - pc.particle_count : rec.particles.y - pc.particle_count;
    float3 turn = float3(0, 0, 0);
    if (j < chain.y) {
      const float3 dl = chain_scratch[2 * c + 1].xyz;
      lambdas[3 * c] += dl.x;
      lambdas[3 * c + 1] += dl.y;
      lambdas[3 * c + 2] += dl.z;
      turn = -dl * chain_scratch[2 * c].z;
    }
    const float w = frame_weight(e);
    if (w > 0) {
      const float4 q = orientations[e];
      orientations[e] = normalize(q + w * quat_mul(q, float4(turn - turn_prev, 0)));
    }
    turn_prev = turn;
  }
}
