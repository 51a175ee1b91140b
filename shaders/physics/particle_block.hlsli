// The workgroup solve's walk over one family's colours for one env, shared by particle_solve.hlsli
// (one family a dispatch) and particle_iterations (every family and the contacts of a substep in
// one dispatch). Expects `groupshared float4 block_x[]` holding the env's particles (env-local
// indices) and xpbd_delta (particle_xpbd.hlsli).
//   EVALUATE  the family's constraint (particle_<family>.hlsli)
//   RECORDS   its 16-byte records (PARTICLE_BLOCK_NONE in cressim/particle.h says the layout)
//   LAMBDAS   its multipliers; COLOURS its (first, count) per env and colour
//   ZW(c)     record c's params.zw, for a family whose constraint reads them (else float2(0, 0))
// `passes` times over the env's `colours` colours, a group barrier after each colour.
#define BLOCK_SOLVE_COLOURS(EVALUATE, RECORDS, LAMBDAS, COLOURS, ZW, env, colours, passes, lane, threads)        \
  for (uint pass_ = 0; pass_ < (passes); ++pass_) {                                                           \
    for (uint k_ = 0; k_ < (colours); ++k_) {                                                                 \
      const uint2 r_ = COLOURS[(env) * (colours) + k_];                                                      \
      for (uint j_ = (lane); j_ < r_.y; j_ += (threads)) {                                                    \
        const uint c_ = r_.x + j_;                                                                            \
        /* record and multiplier loaded together: the cut flag is in the record's compliance */            \
        const uint4 packed_ = RECORDS[c_];                                                                    \
        const float lambda_ = LAMBDAS[c_];                                                                    \
        const uint ids_[4] = {packed_.x & 0xFFFF, packed_.x >> 16, packed_.y & 0xFFFF, packed_.y >> 16};     \
        ParticleConstraint rec_;                                                                              \
        rec_.particles = uint4(0, 0, 0, 0); /* the constraint reads positions, not indices */                \
        rec_.params = float4(asfloat(packed_.z), asfloat(packed_.w), ZW(c_));                                 \
        float3 x_[4];                                                                                         \
        float w_[4];                                                                                          \
        for (uint m_ = 0; m_ < 4; ++m_) {                                                                     \
          const float4 p_ = ids_[m_] == PARTICLE_BLOCK_NONE ? float4(0, 0, 0, 0) : block_x[ids_[m_]];         \
          x_[m_] = p_.xyz;                                                                                    \
          w_[m_] = p_.w;                                                                                      \
        }                                                                                                     \
        float C_;                                                                                             \
        float3 g_[4];                                                                                         \
        const uint n_ = EVALUATE(rec_, x_, C_, g_);                                                           \
        if (rec_.params.y >= 0) {                                                                             \
          const float dl_ = xpbd_delta(rec_, n_, C_, g_, w_, lambda_);                                        \
          LAMBDAS[c_] = lambda_ + dl_;                                                                        \
          for (uint m_ = 0; m_ < n_; ++m_) block_x[ids_[m_]] = float4(x_[m_] + w_[m_] * dl_ * g_[m_], w_[m_]); \
        }                                                                                                     \
      }                                                                                                       \
      GroupMemoryBarrierWithGroupSync();                                                                      \
    }                                                                                                         \
  }

// params.zw of a family that does not read them
#define BLOCK_NO_ZW(c) float2(0, 0)
