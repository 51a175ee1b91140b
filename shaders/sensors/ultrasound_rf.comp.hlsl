// RF on request: the same pulse convolution as ultrasound_iq, evaluated at the full sampling
// rate and modulated back onto the carrier, rf(t) = Re{iq(t) exp(i 2 pi f0 t)} with t the
// two-way time of the depth, time-gain compensated as the IQ. RF sample j sits at depth
// (j + 0.5) dz / rf_factor.
// Threads: (RF sample, scanline, probe).
#include "cressim/layout.h"
#include "cressim/ultrasound.h"

[[vk::push_constant]] ConstantBuffer<UltrasoundConstants> pc;
StructuredBuffer<UltrasoundProbeData> probes;
StructuredBuffer<int> accumulator;  // (probes, lines, bins, 2) fixed point
RWStructuredBuffer<float> rf;       // (probes, lines, samples * rf_factor)

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint j = id.x, scanline = id.y, probe = id.z, count = pc.samples * pc.rf_factor;
  if (j >= count || scanline >= pc.lines || probe >= pc.probe_count) return;
  const UltrasoundProbeData p = probes[probe];
  const float depth = (float(j) + 0.5) * p.pulse.x / float(pc.rf_factor);
  const float v = depth / p.beam.z - 0.5;  // in bins
  const float radius = p.pulse.w, step = p.beam.z / p.pulse.y;
  const int lo = max(int(ceil(v - radius)), 0);
  const int hi = min(int(floor(v + radius)), int(float(pc.samples) * p.beam.w) - 1);
  const uint base = (probe * pc.lines + scanline) * pc.bins;
  float2 sum = float2(0, 0);
  for (int m = lo; m <= hi; ++m) {
    const float t = (float(m) - v) * step;
    const uint i = 2 * (base + uint(m));
    sum += exp(-0.5 * t * t) * float2(float(accumulator[i]), float(accumulator[i + 1]));
  }
  const float phase = p.pulse.z * depth;
  const float tgc = exp(p.display.z * depth * (log(10.0) / 20.0));
  rf[(probe * pc.lines + scanline) * count + j] = (sum.x * cos(phase) - sum.y * sin(phase)) * tgc / ULTRASOUND_FIXED_POINT;
}
