// COLE step 3: envelope, log compression and scan conversion. Each output pixel is mapped to
// (scanline, sample) coordinates of its probe (linear: rectangular; sector: polar), the
// envelope |IQ| interpolated bilinearly, then shown as 1 + (20 log10(envelope) + gain) /
// dynamic range, clamped to [0, 1]. Pixels outside the scanned region are 0. The image is also
// written as uint8 (round(255 x shown)), four pixels to a word.
// Threads: words of four consecutive pixels of the (probes, height, width) output, strided.
#include "cressim/layout.h"
#include "cressim/ultrasound.h"

[[vk::push_constant]] ConstantBuffer<UltrasoundConstants> pc;
StructuredBuffer<UltrasoundProbeData> probes;
StructuredBuffer<float2> iq;          // (probes, lines, samples)
RWStructuredBuffer<float> image;      // (probes, height, width)
RWStructuredBuffer<uint> image_u8;    // (probes, height, width) bytes, four to a word

float envelope(uint base, uint scanline, uint at) { return length(iq[base + scanline * pc.samples + at]); }

float shown(uint probe, uint row, uint col) {
  const UltrasoundProbeData p = probes[probe];
  const float x = p.image.x + (col + 0.5) * p.image.z, z = p.image.y + (row + 0.5) * p.image.w;
  const float last = float(pc.lines - 1);
  float u, depth;  // scanline coordinate, depth along the scanline
  if (p.ids.z == PROBE_LINEAR) {
    u = clamp((x - p.geometry.w) / p.geometry.x, 0.0, last);
    depth = z;
  } else {
    const float R = p.geometry.y, zc = z + R;
    u = (atan2(x, zc) - p.geometry.w) / p.geometry.x;
    depth = length(float2(x, zc)) - R;
  }
  if (!(u >= 0 && u <= last && depth >= 0 && depth <= p.geometry.z)) return 0;
  const float v = depth / p.pulse.x - 0.5;  // sample k sits at depth (k + 0.5) dz
  const uint base = probe * pc.lines * pc.samples;
  const float vc = clamp(v, 0.0, float(pc.samples - 1));
  const uint l0 = min(uint(u), pc.lines - 1), l1 = min(l0 + 1, pc.lines - 1);
  const uint s0 = min(uint(vc), pc.samples - 1), s1 = min(s0 + 1, pc.samples - 1);
  const float fu = u - float(l0), fv = vc - float(s0);
  const float e = lerp(lerp(envelope(base, l0, s0), envelope(base, l0, s1), fv),
                       lerp(envelope(base, l1, s0), envelope(base, l1, s1), fv), fu);
  const float db = 20.0 * log10(max(e, 1e-30)) + p.display.y;
  return saturate(1.0 + db / p.display.x);
}

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint layer = pc.width * pc.height, total = layer * pc.probe_count;
  for (uint word = id.x; word * 4 < total; word += pc.stride) {
    uint packed = 0;
    for (uint k = 0; k < 4 && word * 4 + k < total; ++k) {
      const uint pixel = word * 4 + k, probe = pixel / layer, at = pixel % layer;
      const float value = shown(probe, at / pc.width, at % pc.width);
      image[pixel] = value;
      packed |= uint(round(value * 255.0)) << (8 * k);
    }
    image_u8[word] = packed;
  }
}
