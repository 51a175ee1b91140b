// Layouts shared by the ultrasound sensor (engine/sensors) and shaders/sensors: COLE B-mode
// synthesis (Storve & Torp 2017, after Gao et al. 2009). Lengths are scene units.
#ifndef CRESSIM_ULTRASOUND_H
#define CRESSIM_ULTRASOUND_H
#include "cressim/types.h"

CRESSIM_SHADER_BEGIN

static const uint PROBE_LINEAR = 1;
static const uint PROBE_SECTOR = 2;

// IQ contributions are summed with integer atomics in this fixed point: sums are exact and
// do not depend on the order threads run in (float atomics are optional in Vulkan).
static const float ULTRASOUND_FIXED_POINT = 65536.0;

// A scatterer's carrier (ultrasound.scatterer_carrier.x): an entity row whose pose carries its
// local position, or, with this bit, a tetrahedron (ultrasound.tets row) whose four particles
// carry it by barycentric weights (scatterer xyz = weights of particles 1-3; particle 0 gets the rest).
static const uint ULTRASOUND_TET_CARRIER = 0x80000000u;

// A probe looks along its entity's +z; scanlines are spread along x, y is the elevation.
// Scanline l of a linear probe starts at x = geometry.w + l * geometry.x on the face; a sector
// probe's lines leave an apex geometry.y behind the face at angles geometry.w + l * geometry.x.
struct UltrasoundProbeData {
  uint4 ids;        // x entity row, y env, z kind, w output layer
  float4 geometry;  // x line step (units or rad), y apex radius, z line length, w first line (offset or angle)
  // x IQ sample spacing along a line, y axial sigma of the envelope, z two-way wavenumber
  // (rad/unit), w pulse kernel radius in bins (cut at 4 sigma)
  float4 pulse;
  // x lateral sigma, y elevational sigma (at the focus; cut at 3 sigma), z bin spacing (a
  // scatterer's envelope sits at its bin's centre, its phase at its exact depth), w bins per IQ sample
  float4 beam;
  float4 image;     // x left edge, y top edge, z pixel width, w pixel height
  float4 display;   // x dynamic range (dB), y gain (dB), z time-gain compensation (dB per unit of depth)
  // depth dependence: x focal depth (0: no focus, the beam keeps its width), y lateral and
  // z elevational Rayleigh ranges of the focused beam, w two-way attenuation in dB per unit of
  // depth per (dB/cm/MHz) of the tissue (2 x f0 in MHz x centimetres per unit)
  float4 depth;
  uint4 media;      // x first, y count of its env's media (ultrasound.media rows)
  float4 specular;  // x echo of a perfect plane reflector (scatterer amplitudes), y coupling impedance (MRayl)
};

// A rigid tissue's region as a medium the scanlines cross (ultrasound_medium): in the frame of
// entity row ids.x, centred at center.xyz; where regions overlap, the later tissue's holds.
static const uint ULTRASOUND_BOX = 1;
static const uint ULTRASOUND_SPHERE = 2;
static const uint ULTRASOUND_CYLINDER = 3;  // radius size.x around z, half height size.y
struct UltrasoundMedium {
  uint4 ids;      // x entity row, y region kind
  float4 center;  // xyz region centre in the entity frame, w impedance (MRayl)
  // xyz box half extents (sphere: radius x; cylinder: radius x, half height y), w attenuation
  // (dB/cm/MHz)
  float4 size;
};

struct UltrasoundConstants {
  uint probe_count;
  uint lines;     // scanlines per probe
  uint samples;   // IQ samples per scanline
  uint bins;      // accumulator bins per scanline (the most of any probe: samples x its bins per sample)
  uint width;     // output image
  uint height;
  uint rf_factor;  // RF samples per IQ sample ("ultrasound0.rf"), 0: no RF
  // projection, one pass per chunk (a run of scatterers that one storage binding holds; an env's
  // may span several): the chunk's first probe (probe_count probes from there)
  uint probe_first;
  // threads along x of a strided pass, each taking every stride-th item (projection: scatterers
  // of its probe's env; scan conversion: words of four pixels), so any count fits the dispatch
  uint stride;
};

CRESSIM_SHADER_END
#endif
