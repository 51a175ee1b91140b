#include "sensors/ultrasound_sensor.h"

#include <algorithm>
#include <cstring>

#include "gpu/commands.h"
#include "gpu/context.h"

namespace cressim::sensors {
namespace {

using compute::DType;

template <class T>
std::shared_ptr<compute::TypedBuffer> make(std::shared_ptr<gpu::Context> ctx, BufferMap& into, const std::string& key,
                                           const std::vector<T>& data, std::vector<int64_t> shape, DType t,
                                           uint64_t generation, bool exportable = false) {
  return compute::make_keyed_buffer(std::move(ctx), into, key, data, std::move(shape), t, true, generation, exportable);
}

}  // namespace

UltrasoundSensor::UltrasoundSensor(std::shared_ptr<gpu::Context> ctx, UltrasoundModel model, uint64_t generation,
                                   BufferMap& internal, const BufferMap& scene)
    : model_(std::move(model)) {
  const bool exportable = ctx->external_memory_fd && !ctx->unified_memory;
  const auto& m = model_;
  const int64_t P = int64_t(m.probes.size()), N = int64_t(m.scatterers.size()), E = int64_t(m.env_scatterers.size());
  const int64_t lines = m.lines, samples = m.samples;
  std::vector<uint32_t> ranges;
  for (auto& r : m.env_scatterers) ranges.insert(ranges.end(), r.begin(), r.end());
  auto probes = make(ctx, internal, "ultrasound.probes", m.probes,
                     {P, int64_t(sizeof(shader::UltrasoundProbeData) / 4)}, DType::UINT32, generation);
  auto scatterers = make(ctx, internal, "ultrasound.scatterers", m.scatterers, {N, 4}, DType::FLOAT32, generation);
  auto carriers = make(ctx, internal, "ultrasound.scatterer_carrier", m.scatterer_carrier, {N, 2}, DType::UINT32,
                       generation);
  // tables padded to one row: a binding needs a buffer even when no tissue is soft
  auto attenuation = m.tissue_attenuation.empty() ? std::vector<float>{0.f} : m.tissue_attenuation;
  auto tets = m.tets.empty() ? std::vector<shader::uint4>{{0, 0, 0, 0}} : m.tets;
  auto tissues = make(ctx, internal, "ultrasound.tissue_attenuation", attenuation, {int64_t(attenuation.size())},
                      DType::FLOAT32, generation);
  auto tet_table = make(ctx, internal, "ultrasound.tets", tets, {int64_t(tets.size()), 4}, DType::UINT32, generation);
  auto particles = scene.count("particles.positions")
                       ? scene.at("particles.positions")
                       : make(ctx, internal, "ultrasound.no_particles", std::vector<float>(4, 0.f), {1, 4},
                              DType::FLOAT32, generation);
  auto env_ranges = make(ctx, internal, "ultrasound.env_scatterers", ranges, {E, 2}, DType::UINT32, generation);
  accumulator_ = make(ctx, internal, "ultrasound0.accumulator", std::vector<int32_t>{}, {P, lines, samples, 2},
                      DType::INT32, generation);
  auto iq = make(ctx, internal, "ultrasound0.iq", std::vector<float>{}, {P, lines, samples, 2}, DType::FLOAT32,
                 generation, exportable);
  auto image = make(ctx, internal, "ultrasound0.image", std::vector<float>{},
                    {P, int64_t(m.height), int64_t(m.width)}, DType::FLOAT32, generation, exportable);

  const shader::UltrasoundConstants c{uint32_t(P), m.lines, m.samples, m.width, m.height, m.max_env_scatterers,
                                      m.rf_factor};
  auto constants = [&](compute::ComputePass& pass) {
    if (pass.constants.size() != sizeof(c)) throw std::logic_error("UltrasoundConstants does not match " + pass.name);
    std::memcpy(pass.constants.data(), &c, sizeof(c));
    ++pass.version;
  };
  project_ = compute::create_builtin_pass(
      ctx, "sensors/ultrasound_project",
      {{"probes", probes}, {"scatterers", scatterers}, {"scatterer_carrier", carriers}, {"env_scatterers", env_ranges},
       {"tissue_attenuation", tissues}, {"tets", tet_table}, {"particle_positions", particles},
       {"positions", scene.at("transform.positions")}, {"rotations", scene.at("transform.rotations")},
       {"accumulator", accumulator_}});
  constants(*project_);
  project_->set_threads({std::max<uint64_t>(m.max_env_scatterers, 1), uint64_t(P), 1});
  demodulate_ = compute::create_builtin_pass(ctx, "sensors/ultrasound_iq",
                                             {{"probes", probes}, {"accumulator", accumulator_}, {"iq", iq}});
  constants(*demodulate_);
  demodulate_->set_threads({uint64_t(samples), uint64_t(lines), uint64_t(P)});
  scan_convert_ = compute::create_builtin_pass(ctx, "sensors/ultrasound_scan_convert",
                                               {{"probes", probes}, {"iq", iq}, {"image", image}});
  constants(*scan_convert_);
  scan_convert_->set_threads({uint64_t(m.width) * m.height, uint64_t(P), 1});
  if (!m.rf_factor) return;
  const int64_t rf_samples = samples * m.rf_factor;
  auto rf = make(ctx, internal, "ultrasound0.rf", std::vector<float>{}, {P, lines, rf_samples}, DType::FLOAT32,
                 generation, exportable);
  modulate_ = compute::create_builtin_pass(ctx, "sensors/ultrasound_rf",
                                           {{"probes", probes}, {"accumulator", accumulator_}, {"rf", rf}});
  constants(*modulate_);
  modulate_->set_threads({uint64_t(rf_samples), uint64_t(lines), uint64_t(P)});
}

void UltrasoundSensor::record(VkCommandBuffer cmd) const {
  vkCmdFillBuffer(cmd, accumulator_->storage->buffer.buffer, 0, VK_WHOLE_SIZE, 0);
  gpu::compute_barrier(cmd);
  project_->record(cmd);
  gpu::compute_barrier(cmd);
  demodulate_->record(cmd);
  if (modulate_) modulate_->record(cmd);
  gpu::compute_barrier(cmd);
  scan_convert_->record(cmd);
}

}  // namespace cressim::sensors
