// prepare() for the ultrasound sensor: every probe's geometry and pulse worked out into
// UltrasoundProbeData, and every tissue's scatterers generated in its entity frame.
// A scatterer is (local position, amplitude) plus the entity row whose pose carries it; soft
// tissue will carry them by particle or tetrahedron (barycentric) the same way.
#pragma once
#include <cstdint>
#include <vector>

#include "cressim/ultrasound.h"
#include "scene/layout_mapping.h"
#include "scene/world.h"

namespace cressim::sensors {

struct UltrasoundModel {
  std::vector<shader::UltrasoundProbeData> probes;  // one output layer each, envs in order
  std::vector<uint32_t> probe_entity;
  std::vector<shader::float4> scatterers;  // xyz in the parent's frame, w amplitude
  std::vector<uint32_t> scatterer_parent;  // entity row
  std::vector<std::array<uint32_t, 2>> env_scatterers;  // per env: first, count
  uint32_t lines = 0, samples = 0, width = 0, height = 0, max_env_scatterers = 0;
  uint32_t rf_factor = 0;  // RF samples per IQ sample (the decimation) when RF is asked for, else 0

  bool empty() const { return probes.empty(); }
};

UltrasoundModel build_ultrasound_model(const scene::World& world, const scene::LayoutMapping& mapping);

}  // namespace cressim::sensors
