// Tissue boundaries along each scanline (ray model): the line is marched bin by bin through the
// media of its env (rigid tissues' regions, the later one where they overlap; outside them the
// coupling medium, no loss). Each bin gets the two-way amplitude factor at its centre, `path`:
// the attenuation accumulated through the media crossed (alpha f0 2 per unit of depth in each)
// times (1 - R) for every interface crossed, R = ((Z2 - Z1) / (Z2 + Z1))^2 the intensity
// reflection coefficient (the pressure transmission there and back, t12 t21 = 1 - R). An
// interface, found between two bin centres by bisection, echoes specularly: r = (Z2 - Z1) /
// (Z2 + Z1) times the factor that reaches it, times the probe's plane-reflector amplitude, added
// with the phase of its exact depth to the bin that holds it. Behind a bone or a calcification
// (high impedance and attenuation) the factor falls: its acoustic shadow.
// Threads: (scanline, probe).
#include "cressim/layout.h"
#include "cressim/quat.h"
#include "cressim/ultrasound.h"

[[vk::push_constant]] ConstantBuffer<UltrasoundConstants> pc;
StructuredBuffer<UltrasoundProbeData> probes;
StructuredBuffer<UltrasoundMedium> media;
StructuredBuffer<float4> positions;   // transform.* rows
StructuredBuffer<float4> rotations;
RWStructuredBuffer<float> path;       // (probes, lines, bins) two-way amplitude factor
RWStructuredBuffer<int> accumulator;  // (probes, lines, bins, 2) fixed point

bool inside(UltrasoundMedium m, float3 world) {
  const float3 q = quat_unrotate(rotations[m.ids.x], world - positions[m.ids.x].xyz) - m.center.xyz;
  if (m.ids.y == ULTRASOUND_SPHERE) return dot(q, q) <= m.size.x * m.size.x;
  if (m.ids.y == ULTRASOUND_CYLINDER) return dot(q.xy, q.xy) <= m.size.x * m.size.x && abs(q.z) <= m.size.y;
  return all(abs(q) <= m.size.xyz);
}

// the medium at a depth along the line: its index, or -1 for the coupling medium
int medium_at(UltrasoundProbeData p, uint scanline, float depth) {
  const float a = p.geometry.w + float(scanline) * p.geometry.x, R = p.geometry.y;
  const float3 local = p.ids.z == PROBE_LINEAR ? float3(a, 0, depth)
                                               : float3((R + depth) * sin(a), 0, (R + depth) * cos(a) - R);
  const uint eye = p.ids.x;
  const float3 world = positions[eye].xyz + quat_rotate(rotations[eye], local);
  int found = -1;
  for (uint i = 0; i < p.media.y; ++i)
    if (inside(media[p.media.x + i], world)) found = int(p.media.x + i);
  return found;
}

float2 acoustics(UltrasoundProbeData p, int m) {  // impedance, attenuation
  return m < 0 ? float2(p.specular.y, 0) : float2(media[m].center.w, media[m].size.w);
}

[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  const uint scanline = id.x, probe = id.y;
  if (scanline >= pc.lines || probe >= pc.probe_count) return;
  const UltrasoundProbeData p = probes[probe];
  const float bin = p.beam.z;
  const uint count = uint(float(pc.samples) * p.beam.w), base = (probe * pc.lines + scanline) * pc.bins;
  int before = -1;
  float at = 0, decibels = 0, transmitted = 1;  // depth of the last bin centre (the face first)
  for (uint j = 0; j < count; ++j) {
    const float centre = (float(j) + 0.5) * bin;
    const int here = medium_at(p, scanline, centre);
    float edge = at;  // where the medium changes between the two centres
    if (here != before) {
      float lo = at, hi = centre;
      for (int k = 0; k < 12; ++k) {
        const float mid = 0.5 * (lo + hi);
        if (medium_at(p, scanline, mid) == before) lo = mid;
        else hi = mid;
      }
      edge = 0.5 * (lo + hi);
    }
    const float2 z1 = acoustics(p, before), z2 = acoustics(p, here);
    decibels += p.depth.w * (z1.y * (edge - at) + z2.y * (centre - edge));
    if (z1.x != z2.x) {
      const float r = (z2.x - z1.x) / (z2.x + z1.x);
      const float echo = p.specular.x * r * transmitted * exp(-(decibels - p.depth.w * z2.y * (centre - edge)) *
                                                              (log(10.0) / 20.0));
      const uint i = 2 * (base + min(uint(edge / bin), count - 1));
      const float phase = -p.pulse.z * edge;
      InterlockedAdd(accumulator[i], int(round(echo * cos(phase) * ULTRASOUND_FIXED_POINT)));
      InterlockedAdd(accumulator[i + 1], int(round(echo * sin(phase) * ULTRASOUND_FIXED_POINT)));
      transmitted *= 1 - r * r;
    }
    path[base + j] = transmitted * exp(-decibels * (log(10.0) / 20.0));
    before = here, at = centre;
  }
}
