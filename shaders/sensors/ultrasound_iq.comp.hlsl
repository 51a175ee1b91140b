// COLE step 2: the projected contributions of each scanline convolved with the pulse's
// Gaussian envelope (axial sigma from the centre frequency and bandwidth): the baseband (IQ)
// signal after demodulation, with the probe's time-gain compensation (dB per unit of depth)
// applied at the sample's depth. Threads: (sample, scanline, probe).
#include "cressim/layout.h"
#include "cressim/ultrasound.h"

[[vk::push_constant]] ConstantBuffer<UltrasoundConstants> pc;
StructuredBuffer<UltrasoundProbeData> probes;
StructuredBuffer<int> accumulator;  // (probes, lines, samples, 2) fixed point
RWStructuredBuffer<float2> iq;      // (probes, lines, samples)

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint k = id.x, scanline = id.y, probe = id.z;
  if (k >= pc.samples || scanline >= pc.lines || probe >= pc.probe_count) return;
  const UltrasoundProbeData p = probes[probe];
  const int radius = int(p.pulse.w);
  const float step = p.pulse.x / p.pulse.y;  // sample spacing in envelope sigmas
  const uint base = (probe * pc.lines + scanline) * pc.samples;
  const int lo = max(int(k) - radius, 0), hi = min(int(k) + radius, int(pc.samples) - 1);
  float2 sum = float2(0, 0);
  for (int m = lo; m <= hi; ++m) {
    const float t = float(m - int(k)) * step;
    const uint i = 2 * (base + uint(m));
    sum += exp(-0.5 * t * t) * float2(float(accumulator[i]), float(accumulator[i + 1]));
  }
  const float tgc = exp(p.display.z * (float(k) + 0.5) * p.pulse.x * (log(10.0) / 20.0));
  iq[base + k] = sum * (tgc / ULTRASOUND_FIXED_POINT);
}
