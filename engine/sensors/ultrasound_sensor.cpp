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

std::vector<ScattererChunk> split_scatterers(const UltrasoundModel& m, uint64_t max_binding_bytes) {
  const uint64_t per_chunk = std::max<uint64_t>(max_binding_bytes / sizeof(shader::float4), 1);
  const uint64_t total = m.scatterers.size();
  std::vector<ScattererChunk> chunks;
  for (uint64_t first = 0; first < std::max<uint64_t>(total, 1); first += per_chunk) {
    ScattererChunk c{first, std::min(first + per_chunk, total), uint32_t(m.probes.size()), 0, {}};
    for (uint32_t probe = 0; probe < m.probes.size(); ++probe) {
      const auto [env_first, env_count] = m.env_scatterers[m.probes[probe].ids.y];
      const uint64_t lo = std::max<uint64_t>(env_first, c.first), hi = std::min<uint64_t>(env_first + env_count, c.end);
      if (lo >= hi && total) continue;
      c.probe_first = std::min(c.probe_first, probe);
      c.probe_count = probe + 1 - c.probe_first;
      c.ranges.resize(c.probe_count, {0, 0});
      if (lo < hi) c.ranges[probe - c.probe_first] = {uint32_t(lo - c.first), uint32_t(hi - lo)};
    }
    if (c.probe_count) chunks.push_back(std::move(c));
  }
  return chunks;
}

UltrasoundSensor::UltrasoundSensor(std::shared_ptr<gpu::Context> ctx, UltrasoundModel model, uint64_t generation,
                                   BufferMap& internal, const BufferMap& scene)
    : model_(std::move(model)) {
  const bool exportable = ctx->external_memory_fd && !ctx->unified_memory;
  const auto& m = model_;
  const int64_t P = int64_t(m.probes.size()), E = int64_t(m.env_scatterers.size());
  const int64_t lines = m.lines, samples = m.samples;
  std::vector<uint32_t> ranges;
  for (auto& r : m.env_scatterers) ranges.insert(ranges.end(), r.begin(), r.end());
  auto probes = make(ctx, internal, "ultrasound.probes", m.probes,
                     {P, int64_t(sizeof(shader::UltrasoundProbeData) / 4)}, DType::UINT32, generation);
  // tables padded to one row: a binding needs a buffer even when no tissue is soft
  auto attenuation = m.tissue_attenuation.empty() ? std::vector<float>{0.f} : m.tissue_attenuation;
  auto tets = m.tets.empty() ? std::vector<shader::uint4>{{0, 0, 0, 0}} : m.tets;
  auto media = m.media.empty() ? std::vector<shader::UltrasoundMedium>(1) : m.media;
  auto tissues = make(ctx, internal, "ultrasound.tissue_attenuation", attenuation, {int64_t(attenuation.size())},
                      DType::FLOAT32, generation);
  auto media_table = make(ctx, internal, "ultrasound.media", media,
                          {int64_t(media.size()), int64_t(sizeof(shader::UltrasoundMedium) / 4)}, DType::UINT32,
                          generation);
  auto tet_table = make(ctx, internal, "ultrasound.tets", tets, {int64_t(tets.size()), 4}, DType::UINT32, generation);
  auto particles = scene.count("particles.positions")
                       ? scene.at("particles.positions")
                       : make(ctx, internal, "ultrasound.no_particles", std::vector<float>(4, 0.f), {1, 4},
                              DType::FLOAT32, generation);
  make(ctx, internal, "ultrasound.env_scatterers", ranges, {E, 2}, DType::UINT32, generation);
  accumulator_ = make(ctx, internal, "ultrasound0.accumulator", std::vector<int32_t>{}, {P, lines, int64_t(m.bins), 2},
                      DType::INT32, generation);
  auto path = make(ctx, internal, "ultrasound0.path", std::vector<float>{}, {P, lines, int64_t(m.bins)},
                   DType::FLOAT32, generation);
  auto iq = make(ctx, internal, "ultrasound0.iq", std::vector<float>{}, {P, lines, samples, 2}, DType::FLOAT32,
                 generation, exportable);
  auto image = make(ctx, internal, "ultrasound0.image", std::vector<float>{},
                    {P, int64_t(m.height), int64_t(m.width)}, DType::FLOAT32, generation, exportable);

  const shader::UltrasoundConstants c{uint32_t(P), m.lines, m.samples, m.bins, m.width, m.height, m.rf_factor, 0, 0};
  auto constants = [&](compute::ComputePass& pass, const shader::UltrasoundConstants& values) {
    if (pass.constants.size() != sizeof(values))
      throw std::logic_error("UltrasoundConstants does not match " + pass.name);
    std::memcpy(pass.constants.data(), &values, sizeof(values));
    ++pass.version;
  };
  medium_ = compute::create_builtin_pass(
      ctx, "sensors/ultrasound_medium",
      {{"probes", probes}, {"media", media_table}, {"positions", scene.at("transform.positions")},
       {"rotations", scene.at("transform.rotations")}, {"path", path}, {"accumulator", accumulator_}});
  constants(*medium_, c);
  medium_->set_threads({uint64_t(lines), uint64_t(P), 1});
  // projection: one pass per chunk of scatterers that fits the device's storage binding range
  // (an env's may span several); x strides over the chunk's scatterers of a probe's env
  const uint64_t x_groups = ctx->properties.limits.maxComputeWorkGroupCount[0];
  const auto chunks = split_scatterers(m, ctx->properties.limits.maxStorageBufferRange);
  for (size_t k = 0; k < chunks.size(); ++k) {
    const auto& ch = chunks[k];
    const std::string suffix = k ? "." + std::to_string(k) : "";
    const int64_t n = int64_t(ch.end - ch.first);
    auto scatterers = make_keyed_buffer(ctx, internal, "ultrasound.scatterers" + suffix,
                                        m.scatterers.data() + ch.first, n * sizeof(shader::float4), {n, 4},
                                        DType::FLOAT32, true, generation);
    auto carriers = make_keyed_buffer(ctx, internal, "ultrasound.scatterer_carrier" + suffix,
                                      m.scatterer_carrier.data() + ch.first, n * 2 * sizeof(uint32_t), {n, 2},
                                      DType::UINT32, true, generation);
    auto probe_ranges = make(ctx, internal, "ultrasound.probe_scatterers" + suffix, ch.ranges,
                             {int64_t(ch.probe_count), 2}, DType::UINT32, generation);
    uint32_t most = 1;
    for (const auto& r : ch.ranges) most = std::max(most, r[1]);
    auto pass = compute::create_builtin_pass(
        ctx, "sensors/ultrasound_project",
        {{"probes", probes}, {"scatterers", scatterers}, {"scatterer_carrier", carriers},
         {"probe_scatterers", probe_ranges}, {"tissue_attenuation", tissues}, {"tets", tet_table},
         {"particle_positions", particles}, {"positions", scene.at("transform.positions")},
         {"rotations", scene.at("transform.rotations")}, {"path", path}, {"accumulator", accumulator_}});
    const uint32_t group = pass->pipeline.reflection.local_size[0];
    pass->set_threads({std::min<uint64_t>(most, x_groups * group), ch.probe_count, 1});
    auto chunk_constants = c;
    chunk_constants.probe_first = ch.probe_first, chunk_constants.probe_count = ch.probe_count;
    chunk_constants.scatterer_stride = pass->groups[0] * group;
    constants(*pass, chunk_constants);
    project_.push_back(std::move(pass));
  }
  demodulate_ = compute::create_builtin_pass(ctx, "sensors/ultrasound_iq",
                                             {{"probes", probes}, {"accumulator", accumulator_}, {"iq", iq}});
  constants(*demodulate_, c);
  demodulate_->set_threads({uint64_t(samples), uint64_t(lines), uint64_t(P)});
  scan_convert_ = compute::create_builtin_pass(ctx, "sensors/ultrasound_scan_convert",
                                               {{"probes", probes}, {"iq", iq}, {"image", image}});
  constants(*scan_convert_, c);
  scan_convert_->set_threads({uint64_t(m.width) * m.height, uint64_t(P), 1});
  if (!m.rf_factor) return;
  const int64_t rf_samples = samples * m.rf_factor;
  auto rf = make(ctx, internal, "ultrasound0.rf", std::vector<float>{}, {P, lines, rf_samples}, DType::FLOAT32,
                 generation, exportable);
  modulate_ = compute::create_builtin_pass(ctx, "sensors/ultrasound_rf",
                                           {{"probes", probes}, {"accumulator", accumulator_}, {"rf", rf}});
  constants(*modulate_, c);
  modulate_->set_threads({uint64_t(rf_samples), uint64_t(lines), uint64_t(P)});
}

void UltrasoundSensor::record(VkCommandBuffer cmd) const {
  vkCmdFillBuffer(cmd, accumulator_->storage->buffer.buffer, 0, VK_WHOLE_SIZE, 0);
  gpu::compute_barrier(cmd);
  medium_->record(cmd);
  gpu::compute_barrier(cmd);
  for (const auto& pass : project_) pass->record(cmd);  // atomics: chunks need no barrier between them
  gpu::compute_barrier(cmd);
  demodulate_->record(cmd);
  if (modulate_) modulate_->record(cmd);
  gpu::compute_barrier(cmd);
  scan_convert_->record(cmd);
}

}  // namespace cressim::sensors
