// prepare() for the ultrasound sensor: every probe's geometry, pulse and beam worked out into
// UltrasoundProbeData, and every tissue's scatterers generated: in its entity frame, carried by
// the entity's pose, or, on a tetrahedral SoftBody, inside its tets by barycentric weights,
// carried by the tets' particles (particles.positions).
#pragma once
#include <array>
#include <cstdint>
#include <vector>

#include "cressim/ultrasound.h"
#include "physics/particle_model.h"
#include "scene/layout_mapping.h"
#include "scene/world.h"

namespace cressim::sensors {

// Probes that share scanlines, IQ samples per line, image size and RF output: one set of outputs
// "ultrasound<group>.*" with one layer per probe, envs in order.
struct UltrasoundGroup {
  uint32_t lines = 0, samples = 0, width = 0, height = 0;
  uint32_t bins = 0;       // accumulator bins per scanline (shaders/common/ultrasound.h)
  uint32_t rf_factor = 0;  // RF samples per IQ sample (the decimation) when RF is asked for, else 0
  uint32_t layers = 0;     // its probes
};

struct UltrasoundModel {
  std::vector<shader::UltrasoundProbeData> probes;  // envs in order; ids.w: the layer in its group
  std::vector<uint32_t> probe_entity, probe_group;
  std::vector<UltrasoundGroup> groups;
  std::vector<shader::float4> scatterers;  // xyz in the carrier's frame (or barycentric weights 1-3), w amplitude
  std::vector<std::array<uint32_t, 2>> scatterer_carrier;  // x entity row or tet | ULTRASOUND_TET_CARRIER, y tissue
  std::vector<float> tissue_attenuation;         // per tissue, dB/cm/MHz
  std::vector<shader::UltrasoundMedium> media;   // rigid tissues' regions, envs and entities in order
  std::vector<shader::uint4> tets;               // global particle indices of carrier tets
  std::vector<std::array<uint32_t, 2>> env_scatterers;  // per env: first, count

  bool empty() const { return probes.empty(); }
};

// particles: the prepared particle model (soft tissue's tets are carried by its particles)
UltrasoundModel build_ultrasound_model(const scene::World& world, const scene::LayoutMapping& mapping,
                                       const physics::ParticleModel& particles);

}  // namespace cressim::sensors
