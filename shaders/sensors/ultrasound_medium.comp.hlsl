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
// Workgroups: (scanline, probe), a run of bins per thread.
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

// Marches bins [first, end) from the centre `at` (in medium `before`), adding to the two-way
// loss in dB and the transmission; with `write`, fills `path` and adds the interfaces' echoes.
void march(UltrasoundProbeData p, uint scanline, uint first, uint end, uint base, uint count, bool write, int before,
           float at, inout float decibels, inout float transmitted) {
  const float bin = p.beam.z;
  for (uint j = first; j < end; ++j) {
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
    decibels += p.depth.w * z1.y * (edge - at);
    if (z1.x != z2.x) {
      const float r = (z2.x - z1.x) / (z2.x + z1.x);
      if (write) {
        const float echo = p.specular.x * r * transmitted * exp(-decibels * (log(10.0) / 20.0));
        const uint i = 2 * (base + min(uint(edge / bin), count - 1));
        const float phase = -p.pulse.z * edge;
        InterlockedAdd(accumulator[i], int(round(echo * cos(phase) * ULTRASOUND_FIXED_POINT)));
        InterlockedAdd(accumulator[i + 1], int(round(echo * sin(phase) * ULTRASOUND_FIXED_POINT)));
      }
      transmitted *= 1 - r * r;
    }
    decibels += p.depth.w * z2.y * (centre - edge);
    if (write) path[base + j] = transmitted * exp(-decibels * (log(10.0) / 20.0));
    before = here, at = centre;
  }
}

groupshared float2 totals[CRESSIM_GROUP_SIZE];  // each thread's bins: loss (dB), transmission

// One workgroup per scanline: each thread marches a run of its bins twice, first for the run's
// totals, then, after the runs before it are summed, for the path and the echoes.
[numthreads(CRESSIM_GROUP_SIZE, 1, 1)]
void main(uint3 group : SV_GroupID, uint3 thread : SV_GroupThreadID) {
  const uint scanline = group.x, probe = group.y, t = thread.x;
  const UltrasoundProbeData p = probes[probe];
  if (p.media.y == 0) return;  // nothing to cross: ultrasound_project takes the path as 1
  const uint count = uint(float(pc.samples) * p.beam.w), base = (probe * pc.lines + scanline) * pc.bins;
  const uint run = (count + CRESSIM_GROUP_SIZE - 1) / CRESSIM_GROUP_SIZE;
  const uint first = min(t * run, count), end = min(first + run, count);
  // the run starts from the bin centre before it (the face, in the coupling medium, for the first)
  const float at = first == 0 ? 0.0 : (float(first) - 0.5) * p.beam.z;
  const int before = first == 0 ? -1 : medium_at(p, scanline, at);
  float decibels = 0, transmitted = 1;
  march(p, scanline, first, end, base, count, false, before, at, decibels, transmitted);
  totals[t] = float2(decibels, transmitted);
  GroupMemoryBarrierWithGroupSync();
  decibels = 0, transmitted = 1;
  for (uint k = 0; k < t; ++k) decibels += totals[k].x, transmitted *= totals[k].y;
  march(p, scanline, first, end, base, count, true, before, at, decibels, transmitted);
}
