// The ultrasound sensor on the GPU, recorded into step_simulation_sensors: each scanline traced
// through the rigid tissues' regions (attenuation, interface echoes, shadows), scatterers posed
// by their parents and projected onto every probe's scanlines as IQ contributions, the pulse
// envelope convolved along each line, then envelope, log compression and scan conversion into
// one output layer per probe ("ultrasound0.image" (probes, H, W) float32 in [0, 1],
// "ultrasound0.iq" (probes, lines, samples, 2) float32; with UltrasoundProbe.rf_output also
// "ultrasound0.rf" (probes, lines, samples x radial_decimation) float32).
#pragma once
#include <array>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "compute/compute_pass.h"
#include "sensors/ultrasound_model.h"

namespace cressim::sensors {

using BufferMap = compute::BufferMap;

// A run of scatterers [first, end) that one storage binding holds, and the probes that image
// some of them: ranges[i] is probe probe_first + i's (first relative to the run, count).
struct ScattererChunk {
  uint64_t first = 0, end = 0;
  uint32_t probe_first = 0, probe_count = 0;
  std::vector<std::array<uint32_t, 2>> ranges;
};

// The scatterers split into runs of at most max_binding_bytes of float4 each (an env's may
// span several runs); one run, for every probe, when there are none.
std::vector<ScattererChunk> split_scatterers(const UltrasoundModel& model, uint64_t max_binding_bytes);

class UltrasoundSensor {
 public:
  // internal: receives the sensor's buffers; scene: the engine's transform buffers
  UltrasoundSensor(std::shared_ptr<gpu::Context> ctx, UltrasoundModel model, uint64_t generation, BufferMap& internal,
                   const BufferMap& scene);
  void record(VkCommandBuffer cmd) const;
  const UltrasoundModel& model() const { return model_; }

 private:
  UltrasoundModel model_;
  std::shared_ptr<compute::TypedBuffer> accumulator_;
  std::shared_ptr<compute::ComputePass> medium_;                // tissue boundaries along the lines
  std::vector<std::shared_ptr<compute::ComputePass>> project_;  // one per ScattererChunk
  std::shared_ptr<compute::ComputePass> demodulate_, scan_convert_, modulate_;  // modulate_: RF, on request
};

}  // namespace cressim::sensors
