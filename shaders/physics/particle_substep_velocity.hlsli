// A particle's velocity over the substep (h = pc.gravity.w) from its position at the start (x0)
// and end (x): particle_velocity and the one-workgroup iterations take it this way.
float3 substep_velocity(float3 x, float3 x0) { return (x - x0) / pc.gravity.w; }
