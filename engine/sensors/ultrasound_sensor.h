// The ultrasound sensor on the GPU, recorded into step_simulation_sensors: each scanline traced
// through the rigid tissues' regions (attenuation, interface echoes, shadows), scatterers posed
// by their parents and projected onto every probe's scanlines as IQ contributions, the pulse
// envelope convolved along each line, then envelope, log compression and scan conversion into
// one output layer per probe. Probes that share scanlines, samples, image size and RF form a
// group g with its outputs: "ultrasound<g>.image" (probes, H, W) float32 in [0, 1],
// "ultrasound<g>.image_u8" the same in uint8, "ultrasound<g>.iq" (probes, lines, samples, 2)
// float32; with UltrasoundProbe.rf_output also "ultrasound<g>.rf" (probes, lines, samples x
// radial_decimation) float32.
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

// A run of scatterers [first, end) that one storage binding holds.
struct ScattererChunk {
  uint64_t first = 0, end = 0;
};

// The scatterers split into runs of at most max_binding_bytes of float4 each (an env's may span
// several runs); one empty run when there are none.
std::vector<ScattererChunk> split_scatterers(uint64_t scatterers, uint64_t max_binding_bytes);

class UltrasoundSensor {
 public:
  // internal: receives the sensor's buffers; scene: the engine's transform buffers
  UltrasoundSensor(std::shared_ptr<gpu::Context> ctx, UltrasoundModel model, uint64_t generation, BufferMap& internal,
                   const BufferMap& scene);
  void record(VkCommandBuffer cmd) const;
  // the model as built, less its scatterer tables (dropped on the host once uploaded)
  const UltrasoundModel& model() const { return model_; }
  uint64_t scatterers() const { return scatterers_; }

 private:
  struct Group {  // one output group's accumulator and passes
    std::shared_ptr<compute::TypedBuffer> accumulator;
    std::shared_ptr<compute::ComputePass> medium;                // tissue boundaries along the lines
    std::vector<std::shared_ptr<compute::ComputePass>> project;  // one per ScattererChunk that its probes image
    std::shared_ptr<compute::ComputePass> demodulate, scan_convert, modulate;  // modulate: RF, on request
  };
  UltrasoundModel model_;
  uint64_t scatterers_ = 0;
  std::vector<Group> groups_;
};

}  // namespace cressim::sensors
