// COLE step 1: every scatterer of a probe's env, posed by its carrier (an entity's pose, or a
// tet's four particles by barycentric weights), is projected onto the scanlines within 3 beam
// sigmas: a complex (IQ) contribution of amplitude x the line's two-way path factor at its depth
// (ultrasound_medium: attenuation and transmission through the media crossed) x lateral and
// elevational Gaussian beam weights x exp(-i 2k depth) is added to the accumulator bin that
// holds its depth (bins finer than IQ samples where the pulse needs it, so the binning does not
// alias the carrier: ultrasound_model.cpp). A soft tissue's scatterers, whose moving shape no
// medium traces, also lose their own tissue's attenuation over their whole depth. A focused
// beam's sigmas grow away from the focal depth as a Gaussian beam's (sqrt(1 + (distance /
// z_R)^2)), its on-axis amplitude falling by the same factor per axis. The phase carries the
// exact depth; the pulse envelope is applied by ultrasound_iq.
// Threads: (scatterer of the probe's env in this chunk, strided; probe of the chunk).
#include "cressim/layout.h"
#include "cressim/quat.h"
#include "cressim/ultrasound.h"

[[vk::push_constant]] ConstantBuffer<UltrasoundConstants> pc;
StructuredBuffer<UltrasoundProbeData> probes;
StructuredBuffer<float4> scatterers;         // xyz in the carrier frame (or barycentric weights 1-3), w amplitude
StructuredBuffer<uint2> scatterer_carrier;   // x entity row or tet | ULTRASOUND_TET_CARRIER, y tissue
StructuredBuffer<uint2> probe_scatterers;    // per probe of the chunk: first in this chunk's tables, count
StructuredBuffer<float> tissue_attenuation;  // dB/cm/MHz
StructuredBuffer<uint4> tets;                // particle indices
StructuredBuffer<float4> particle_positions; // particles.positions
StructuredBuffer<float4> positions;          // transform.* rows
StructuredBuffer<float4> rotations;
StructuredBuffer<float> path;                // (probes, lines, bins) two-way amplitude factor
RWStructuredBuffer<int> accumulator;         // (probes, lines, bins, 2) fixed point

void deposit(UltrasoundProbeData p, uint probe, uint scanline, float lateral, float depth, float weight, float sigma) {
  const float at = depth / p.beam.z;
  if (at < 0 || at >= float(pc.samples) * p.beam.w) return;
  const uint bin = (probe * pc.lines + scanline) * pc.bins + uint(at);
  const float crossed = p.media.y ? path[bin] : 1.0;  // ultrasound_medium traces envs with media only
  const float w = weight * crossed * exp(-0.5 * lateral * lateral / (sigma * sigma));
  const float phase = -p.pulse.z * depth;
  InterlockedAdd(accumulator[2 * bin], int(round(w * cos(phase) * ULTRASOUND_FIXED_POINT)));
  InterlockedAdd(accumulator[2 * bin + 1], int(round(w * sin(phase) * ULTRASOUND_FIXED_POINT)));
}

float3 pose(float4 sa, uint carrier) {
  if (carrier & ULTRASOUND_TET_CARRIER) {
    const uint4 t = tets[carrier & ~ULTRASOUND_TET_CARRIER];
    return (1.0 - sa.x - sa.y - sa.z) * particle_positions[t.x].xyz + sa.x * particle_positions[t.y].xyz +
           sa.y * particle_positions[t.z].xyz + sa.z * particle_positions[t.w].xyz;
  }
  return positions[carrier].xyz + quat_rotate(rotations[carrier], sa.xyz);
}

// beam widening at a depth (1 at the focus, or everywhere when unfocused): lateral, elevational
float2 widening(UltrasoundProbeData p, float depth) {
  if (p.depth.x <= 0) return float2(1, 1);
  const float d = depth - p.depth.x;
  return sqrt(1.0 + d * d / (p.depth.yz * p.depth.yz));
}

void project(UltrasoundProbeData p, uint probe, uint s) {
  const float4 sa = scatterers[s];
  const uint2 carrier = scatterer_carrier[s];
  const uint eye = p.ids.x;
  const float3 local = quat_unrotate(rotations[eye], pose(sa, carrier.x) - positions[eye].xyz);
  const float R = p.geometry.y;
  const float r = length(float2(local.x, local.z + R));
  const float depth = p.ids.z == PROBE_LINEAR ? local.z : r - R;  // the beam's and attenuation's depth
  const float2 grow = widening(p, depth);
  const float2 sigma = p.beam.xy * grow;
  if (abs(local.y) > 3.0 * sigma.y) return;
  const bool soft = (carrier.x & ULTRASOUND_TET_CARRIER) != 0;
  const float decibels = soft ? tissue_attenuation[carrier.y] * p.depth.w * max(depth, 0.0) : 0.0;
  const float weight = sa.w * exp(-0.5 * local.y * local.y / (sigma.y * sigma.y)) / (grow.x * grow.y) *
                       exp(-decibels * (log(10.0) / 20.0));
  const float last = float(pc.lines - 1);
  if (p.ids.z == PROBE_LINEAR) {
    const float u = (local.x - p.geometry.w) / p.geometry.x, reach = 3.0 * sigma.x / p.geometry.x;
    const int first = int(ceil(max(u - reach, 0.0))), end = int(floor(min(u + reach, last)));
    for (int l = first; l <= end; ++l)
      deposit(p, probe, uint(l), local.x - (p.geometry.w + l * p.geometry.x), local.z, weight, sigma.x);
  } else {
    if (r <= 0) return;
    const float theta = atan2(local.x, local.z + R), u = (theta - p.geometry.w) / p.geometry.x;
    const float reach = asin(min(3.0 * sigma.x / r, 1.0)) / p.geometry.x;
    const int first = int(ceil(max(u - reach, 0.0))), end = int(floor(min(u + reach, last)));
    for (int l = first; l <= end; ++l) {
      const float d = theta - (p.geometry.w + l * p.geometry.x);
      deposit(p, probe, uint(l), r * sin(d), r * cos(d) - R, weight, sigma.x);
    }
  }
}

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  if (id.y >= pc.probe_count) return;
  const uint probe = pc.probe_first + id.y;
  const UltrasoundProbeData p = probes[probe];
  const uint2 range = probe_scatterers[id.y];
  for (uint i = id.x; i < range.y; i += pc.stride) project(p, probe, range.x + i);
}
