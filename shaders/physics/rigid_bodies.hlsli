// Body access and the two XPBD corrections every rigid constraint is built from
// (Mueller et al. 2020, "Detailed Rigid Body Simulation with Extended Position Based Dynamics").
// Expects `bodies`, `positions`, `rotations` declared by the including kernel.

bool is_dynamic(uint b) { return b != CRESSIM_NONE && bodies[b].inv_inertia.w > 0; }

float3 body_position(uint b) { return b == CRESSIM_NONE ? float3(0, 0, 0) : positions[b].xyz; }
float4 body_rotation(uint b) { return b == CRESSIM_NONE ? float4(0, 0, 0, 1) : rotations[b]; }
float3 to_world(uint b, float3 local) {
  return b == CRESSIM_NONE ? local : positions[b].xyz + quat_rotate(rotations[b], local);
}

// world-frame inverse inertia times v
float3 inv_inertia_times(uint b, float3 v) {
  const float4 q = rotations[b];
  return quat_rotate(q, bodies[b].inv_inertia.xyz * quat_unrotate(q, v));
}

// generalized inverse mass of body b for a correction along n at arm r (world)
float positional_weight(uint b, float3 r, float3 n) {
  if (!is_dynamic(b)) return 0;
  const float3 rn = cross(r, n);
  return bodies[b].inv_inertia.w + dot(rn, inv_inertia_times(b, rn));
}
float angular_weight(uint b, float3 n) { return is_dynamic(b) ? dot(n, inv_inertia_times(b, n)) : 0; }

void move_body(uint b, float3 p, float3 r, float sign) {
  if (!is_dynamic(b)) return;
  positions[b].xyz += sign * p * bodies[b].inv_inertia.w;
  rotations[b] = quat_add_rotation(rotations[b], sign * inv_inertia_times(b, cross(r, p)));
}

void turn_body(uint b, float3 p, float sign) {
  if (!is_dynamic(b)) return;
  rotations[b] = quat_add_rotation(rotations[b], sign * inv_inertia_times(b, p));
}

// Moves body a by +correction (and b by its share of -correction) at world arms ra, rb.
// alpha_tilde = compliance / h^2; lambda accumulates over the substep. Returns the positional
// impulse applied to a (kg m; b got its negative).
float3 correct_position(uint a, uint b, float3 ra, float3 rb, float3 correction, float alpha_tilde,
                       inout float lambda, float max_lambda) {
  const float c = length(correction);
  if (c < 1e-9) return float3(0, 0, 0);
  const float3 n = correction / c;
  const float w = positional_weight(a, ra, n) + positional_weight(b, rb, n);
  if (w + alpha_tilde <= 0) return float3(0, 0, 0);
  float dl = (c - alpha_tilde * lambda) / (w + alpha_tilde);
  dl = clamp(lambda + dl, -max_lambda, max_lambda) - lambda;
  lambda += dl;
  const float3 p = dl * n;
  move_body(a, p, ra, 1);
  move_body(b, p, rb, -1);
  return p;
}

// Turns body a by the rotation vector +correction (b by its share of -correction). Returns the
// angular impulse applied to a (kg m^2; b got its negative).
float3 correct_rotation(uint a, uint b, float3 correction, float alpha_tilde, inout float lambda, float max_lambda) {
  const float c = length(correction);
  if (c < 1e-9) return float3(0, 0, 0);
  const float3 n = correction / c;
  const float w = angular_weight(a, n) + angular_weight(b, n);
  if (w + alpha_tilde <= 0) return float3(0, 0, 0);
  float dl = (c - alpha_tilde * lambda) / (w + alpha_tilde);
  dl = clamp(lambda + dl, -max_lambda, max_lambda) - lambda;
  lambda += dl;
  turn_body(a, dl * n, 1);
  turn_body(b, dl * n, -1);
  return dl * n;
}

// velocity of the material point at world arm r of body b
float3 point_velocity(uint b, float3 r) {
  if (b == CRESSIM_NONE) return float3(0, 0, 0);
  return linear_velocities[b].xyz + cross(angular_velocities[b].xyz, r);
}
