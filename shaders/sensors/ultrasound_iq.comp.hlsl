// COLE step 2: the projected contributions of each scanline (accumulator bins) convolved with
// the pulse's Gaussian envelope (axial sigma from the centre frequency and bandwidth) at each IQ
// sample's depth: the baseband (IQ)
// signal after demodulation, with the probe's time-gain compensation (dB per unit of depth)
// applied at the sample's depth. Threads: (sample, scanline, probe).
#include "cressim/layout.h"
#include "cressim/ultrasound.h"

[[vk::push_constant]] ConstantBuffer<UltrasoundConstants> pc;
StructuredBuffer<UltrasoundProbeData> probes;
StructuredBuffer<int> accumulator;  // (probes, lines, bins, 2) fixed point
RWStructuredBuffer<float2> iq;      // (probes, lines, samples)

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint k = id.x, scanline = id.y, probe = id.z;
  if (k >= pc.samples || scanline >= pc.lines || probe >= pc.probe_count) return;
  const UltrasoundProbeData p = probes[probe];
  const float centre = (float(k) + 0.5) * p.beam.w - 0.5;  // the sample's depth in bins (bin j sits at j + 0.5)
  const float radius = p.pulse.w, step = p.beam.z / p.pulse.y;  // bin spacing in envelope sigmas
  const uint base = (probe * pc.lines + scanline) * pc.bins;
  const int lo = max(int(ceil(centre - radius)), 0);
  const int hi = min(int(floor(centre + radius)), int(float(pc.samples) * p.beam.w) - 1);
  float2 sum = float2(0, 0);
  for (int m = lo; m <= hi; ++m) {
    const float t = (float(m) - centre) * step;
    const uint i = 2 * (base + uint(m));
    sum += exp(-0.5 * t * t) * float2(float(accumulator[i]), float(accumulator[i + 1]));
  }
  const float tgc = exp(p.display.z * (float(k) + 0.5) * p.pulse.x * (log(10.0) / 20.0));
  iq[(probe * pc.lines + scanline) * pc.samples + k] = sum * (tgc / ULTRASOUND_FIXED_POINT);
}
