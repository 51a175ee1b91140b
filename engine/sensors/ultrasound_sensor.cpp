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

void set_constants(compute::ComputePass& pass, const shader::UltrasoundConstants& values) {
  if (pass.constants.size() != sizeof(values))
    throw std::logic_error("UltrasoundConstants does not match " + pass.name);
  std::memcpy(pass.constants.data(), &values, sizeof(values));
  ++pass.version;
}

// threads along x for a pass that strides over `items` (at most the device's groups)
uint64_t strided_threads(const gpu::Context& ctx, const compute::ComputePass& pass, uint64_t items) {
  const uint64_t most = uint64_t(ctx.properties.limits.maxComputeWorkGroupCount[0]) *
                        pass.pipeline.reflection.local_size[0];
  return std::clamp<uint64_t>(items, 1, most);
}

}  // namespace

std::vector<ScattererChunk> split_scatterers(uint64_t scatterers, uint64_t max_binding_bytes) {
  const uint64_t per_chunk = std::max<uint64_t>(max_binding_bytes / sizeof(shader::float4), 1);
  std::vector<ScattererChunk> chunks{{0, std::min(scatterers, per_chunk)}};
  while (chunks.back().end < scatterers)
    chunks.push_back({chunks.back().end, std::min(chunks.back().end + per_chunk, scatterers)});
  return chunks;
}

UltrasoundSensor::UltrasoundSensor(std::shared_ptr<gpu::Context> ctx, UltrasoundModel model, uint64_t generation,
                                   BufferMap& internal, const BufferMap& scene)
    : model_(std::move(model)) {
  const bool exportable = ctx->external_memory_fd && !ctx->unified_memory;
  const auto& m = model_;
  std::vector<uint32_t> ranges;
  for (auto& r : m.env_scatterers) ranges.insert(ranges.end(), r.begin(), r.end());
  make(ctx, internal, "ultrasound.env_scatterers", ranges, {int64_t(m.env_scatterers.size()), 2}, DType::UINT32,
       generation);
  // tables padded to one row: a binding needs a buffer even when no tissue is soft or rigid
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
  const auto& positions = scene.at("transform.positions");
  const auto& rotations = scene.at("transform.rotations");
  // the scatterers in runs that one storage binding holds (chunk k > 0 under keys ending ".k")
  const auto chunks = split_scatterers(m.scatterers.size(), ctx->properties.limits.maxStorageBufferRange);
  std::vector<std::array<std::shared_ptr<compute::TypedBuffer>, 2>> chunk_tables;
  for (size_t k = 0; k < chunks.size(); ++k) {
    const std::string suffix = k ? "." + std::to_string(k) : "";
    const int64_t n = int64_t(chunks[k].end - chunks[k].first);
    chunk_tables.push_back(
        {compute::make_keyed_buffer(ctx, internal, "ultrasound.scatterers" + suffix,
                                    m.scatterers.data() + chunks[k].first, n * sizeof(shader::float4), {n, 4},
                                    DType::FLOAT32, true, generation),
         compute::make_keyed_buffer(ctx, internal, "ultrasound.scatterer_carrier" + suffix,
                                    m.scatterer_carrier.data() + chunks[k].first, n * 2 * sizeof(uint32_t), {n, 2},
                                    DType::UINT32, true, generation)});
  }
  scatterers_ = m.scatterers.size();
  std::vector<shader::float4>().swap(model_.scatterers);  // a G of scatterers is 24 GB on the host
  std::vector<std::array<uint32_t, 2>>().swap(model_.scatterer_carrier);

  for (uint32_t g = 0; g < m.groups.size(); ++g) {
    const auto& info = m.groups[g];
    const std::string prefix = "ultrasound" + std::to_string(g) + ".";
    std::vector<shader::UltrasoundProbeData> layers;
    for (size_t i = 0; i < m.probes.size(); ++i)
      if (m.probe_group[i] == g) layers.push_back(m.probes[i]);
    const int64_t P = int64_t(layers.size()), lines = info.lines, samples = info.samples, bins = info.bins;
    const int64_t H = info.height, W = info.width;
    Group out;
    auto probes = make(ctx, internal, prefix + "probes", layers,
                       {P, int64_t(sizeof(shader::UltrasoundProbeData) / 4)}, DType::UINT32, generation);
    out.accumulator = make(ctx, internal, prefix + "accumulator", std::vector<int32_t>{}, {P, lines, bins, 2},
                           DType::INT32, generation);
    auto path = make(ctx, internal, prefix + "path", std::vector<float>{}, {P, lines, bins}, DType::FLOAT32,
                     generation);
    auto iq = make(ctx, internal, prefix + "iq", std::vector<float>{}, {P, lines, samples, 2}, DType::FLOAT32,
                   generation, exportable);
    auto image = make(ctx, internal, prefix + "image", std::vector<float>{}, {P, H, W}, DType::FLOAT32, generation,
                      exportable);
    // storage in whole words, which the shader writes (four pixels each) through a uint32 view
    const int64_t words = (P * H * W + 3) / 4;
    auto bytes = make(ctx, internal, prefix + "image_u8", std::vector<uint8_t>{}, {words * 4}, DType::UINT8,
                      generation, exportable);
    auto packed = std::make_shared<compute::TypedBuffer>(*bytes);
    packed->shape = {words}, packed->dtype = DType::UINT32;
    bytes->shape = {P, H, W};
    const shader::UltrasoundConstants c{uint32_t(P), info.lines, info.samples, info.bins, info.width, info.height,
                                        info.rf_factor, 0, 0};

    out.medium = compute::create_builtin_pass(ctx, "sensors/ultrasound_medium",
                                              {{"probes", probes}, {"media", media_table}, {"positions", positions},
                                               {"rotations", rotations}, {"path", path},
                                               {"accumulator", out.accumulator}});
    set_constants(*out.medium, c);
    const uint32_t group_size = out.medium->pipeline.reflection.local_size[0];
    out.medium->set_threads({uint64_t(lines) * group_size, uint64_t(P), 1});  // a workgroup a line
    // projection: per chunk, the group's probes whose envs have scatterers in it; x strides over them
    for (size_t k = 0; k < chunks.size(); ++k) {
      const auto& ch = chunks[k];
      uint32_t first = UINT32_MAX, last = 0, most = 0;
      std::vector<std::array<uint32_t, 2>> spans(layers.size(), {0, 0});
      for (uint32_t i = 0; i < layers.size(); ++i) {
        const auto [begin, count] = m.env_scatterers[layers[i].ids.y];
        const uint64_t lo = std::max<uint64_t>(begin, ch.first);
        const uint64_t hi = std::min<uint64_t>(begin + uint64_t(count), ch.end);
        if (lo >= hi) continue;
        spans[i] = {uint32_t(lo - ch.first), uint32_t(hi - lo)};
        first = std::min(first, i), last = i, most = std::max(most, spans[i][1]);
      }
      if (first == UINT32_MAX) continue;
      spans = std::vector<std::array<uint32_t, 2>>(spans.begin() + first, spans.begin() + last + 1);
      const std::string suffix = k ? "." + std::to_string(k) : "";
      auto probe_spans = make(ctx, internal, prefix + "probe_scatterers" + suffix, spans,
                              {int64_t(spans.size()), 2}, DType::UINT32, generation);
      auto pass = compute::create_builtin_pass(
          ctx, "sensors/ultrasound_project",
          {{"probes", probes}, {"scatterers", chunk_tables[k][0]}, {"scatterer_carrier", chunk_tables[k][1]},
           {"probe_scatterers", probe_spans}, {"tissue_attenuation", tissues}, {"tets", tet_table},
           {"particle_positions", particles}, {"positions", positions}, {"rotations", rotations}, {"path", path},
           {"accumulator", out.accumulator}});
      pass->set_threads({strided_threads(*ctx, *pass, most), spans.size(), 1});
      auto values = c;
      values.probe_first = first, values.probe_count = uint32_t(spans.size());
      values.stride = pass->groups[0] * pass->pipeline.reflection.local_size[0];
      set_constants(*pass, values);
      out.project.push_back(std::move(pass));
    }
    out.demodulate = compute::create_builtin_pass(ctx, "sensors/ultrasound_iq",
                                                  {{"probes", probes}, {"accumulator", out.accumulator}, {"iq", iq}});
    set_constants(*out.demodulate, c);
    out.demodulate->set_threads({uint64_t(samples), uint64_t(lines), uint64_t(P)});
    out.scan_convert = compute::create_builtin_pass(
        ctx, "sensors/ultrasound_scan_convert",
        {{"probes", probes}, {"iq", iq}, {"image", image}, {"image_u8", packed}});
    out.scan_convert->set_threads({strided_threads(*ctx, *out.scan_convert, (P * H * W + 3) / 4), 1, 1});
    auto values = c;
    values.stride = out.scan_convert->groups[0] * out.scan_convert->pipeline.reflection.local_size[0];
    set_constants(*out.scan_convert, values);
    if (info.rf_factor) {
      const int64_t rf_samples = samples * info.rf_factor;
      auto rf = make(ctx, internal, prefix + "rf", std::vector<float>{}, {P, lines, rf_samples}, DType::FLOAT32,
                     generation, exportable);
      out.modulate = compute::create_builtin_pass(ctx, "sensors/ultrasound_rf",
                                                  {{"probes", probes}, {"accumulator", out.accumulator}, {"rf", rf}});
      set_constants(*out.modulate, c);
      out.modulate->set_threads({uint64_t(rf_samples), uint64_t(lines), uint64_t(P)});
    }
    groups_.push_back(std::move(out));
  }
}

void UltrasoundSensor::record(VkCommandBuffer cmd) const {
  for (const auto& g : groups_) vkCmdFillBuffer(cmd, g.accumulator->storage->buffer.buffer, 0, VK_WHOLE_SIZE, 0);
  gpu::compute_barrier(cmd);
  for (const auto& g : groups_) g.medium->record(cmd);
  gpu::compute_barrier(cmd);
  for (const auto& g : groups_)
    for (const auto& pass : g.project) pass->record(cmd);  // atomics: chunks need no barrier between them
  gpu::compute_barrier(cmd);
  for (const auto& g : groups_) {
    g.demodulate->record(cmd);
    if (g.modulate) g.modulate->record(cmd);
  }
  gpu::compute_barrier(cmd);
  for (const auto& g : groups_) g.scan_convert->record(cmd);
}

}  // namespace cressim::sensors
