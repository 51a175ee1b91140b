// Quaternion helpers for HLSL passes (xyzw, Hamilton product). HLSL only.
#ifndef CRESSIM_QUAT_H
#define CRESSIM_QUAT_H
#ifndef __cplusplus

float4 quat_mul(float4 a, float4 b) {
  return float4(a.w * b.xyz + b.w * a.xyz + cross(a.xyz, b.xyz), a.w * b.w - dot(a.xyz, b.xyz));
}
float4 quat_conj(float4 q) { return float4(-q.xyz, q.w); }
float3 quat_rotate(float4 q, float3 v) {
  const float3 t = 2.0 * cross(q.xyz, v);
  return v + q.w * t + cross(q.xyz, t);
}
float3 quat_unrotate(float4 q, float3 v) { return quat_rotate(quat_conj(q), v); }
float4 quat_axis_angle(float3 axis, float angle) {
  return float4(axis * sin(0.5 * angle), cos(0.5 * angle));
}
// q advanced by the small rotation vector w (q += 0.5 [w, 0] q), renormalised
float4 quat_add_rotation(float4 q, float3 w) {
  return normalize(q + 0.5 * quat_mul(float4(w, 0), q));
}
// the rotation vector w with quat_add_rotation(q0, w) == q1: a body advanced by w h keeps its
// angular velocity w (2 sin(angle/2) instead would slow a spinning body every substep)
float3 quat_rotation_between(float4 q0, float4 q1) {
  float4 d = quat_mul(q1, quat_conj(q0));
  if (d.w < 0) d = -d;
  return 2.0 * d.xyz / max(d.w, 1e-6);
}

#endif
#endif
