// COLE step 1: every scatterer of a probe's env, posed by its parent entity, is projected onto
// the scanlines within 3 beam sigmas: a complex (IQ) contribution of amplitude x lateral and
// elevational Gaussian beam weights x exp(-i 2k depth) is added to the IQ sample nearest its
// depth. The phase carries the exact depth; the pulse envelope is applied by ultrasound_iq.
// Threads: (scatterer of the env, probe).
#include "cressim/layout.h"
#include "cressim/quat.h"
#include "cressim/ultrasound.h"

[[vk::push_constant]] ConstantBuffer<UltrasoundConstants> pc;
StructuredBuffer<UltrasoundProbeData> probes;
StructuredBuffer<float4> scatterers;      // xyz in the parent frame, w amplitude
StructuredBuffer<uint> scatterer_parent;  // entity row
StructuredBuffer<uint2> env_scatterers;   // first, count
StructuredBuffer<float4> positions;       // transform.* rows
StructuredBuffer<float4> rotations;
RWStructuredBuffer<int> accumulator;      // (probes, lines, samples, 2) fixed point

void deposit(UltrasoundProbeData p, uint probe, uint scanline, float lateral, float depth, float weight) {
  const float at = depth / p.pulse.x;
  if (at < 0 || at >= float(pc.samples)) return;
  const float w = weight * exp(-0.5 * lateral * lateral / (p.beam.x * p.beam.x));
  const float phase = -p.pulse.z * depth;
  const uint i = 2 * ((probe * pc.lines + scanline) * pc.samples + uint(at));
  InterlockedAdd(accumulator[i], int(round(w * cos(phase) * ULTRASOUND_FIXED_POINT)));
  InterlockedAdd(accumulator[i + 1], int(round(w * sin(phase) * ULTRASOUND_FIXED_POINT)));
}

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint probe = id.y;
  if (probe >= pc.probe_count) return;
  const UltrasoundProbeData p = probes[probe];
  const uint2 range = env_scatterers[p.ids.y];
  if (id.x >= range.y) return;
  const uint s = range.x + id.x;
  const float4 sa = scatterers[s];
  const uint parent = scatterer_parent[s], eye = p.ids.x;
  const float3 world = positions[parent].xyz + quat_rotate(rotations[parent], sa.xyz);
  const float3 local = quat_unrotate(rotations[eye], world - positions[eye].xyz);
  if (abs(local.y) > p.beam.w) return;
  const float weight = sa.w * exp(-0.5 * local.y * local.y / (p.beam.y * p.beam.y));
  const float last = float(pc.lines - 1);
  if (p.ids.z == PROBE_LINEAR) {
    const float u = (local.x - p.geometry.w) / p.geometry.x, reach = p.beam.z / p.geometry.x;
    const int first = int(ceil(max(u - reach, 0.0))), end = int(floor(min(u + reach, last)));
    for (int l = first; l <= end; ++l)
      deposit(p, probe, uint(l), local.x - (p.geometry.w + l * p.geometry.x), local.z, weight);
  } else {
    const float R = p.geometry.y, zc = local.z + R;
    const float r = length(float2(local.x, zc));
    if (r <= 0) return;
    const float theta = atan2(local.x, zc), u = (theta - p.geometry.w) / p.geometry.x;
    const float reach = asin(min(p.beam.z / r, 1.0)) / p.geometry.x;
    const int first = int(ceil(max(u - reach, 0.0))), end = int(floor(min(u + reach, last)));
    for (int l = first; l <= end; ++l) {
      const float d = theta - (p.geometry.w + l * p.geometry.x);
      deposit(p, probe, uint(l), r * sin(d), r * cos(d) - R, weight);
    }
  }
}
