#include "render/culling.h"

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <string>

#include "gpu/commands.h"

namespace cressim::render {

using compute::DType;

bool culling_enabled() {
  const char* v = std::getenv("CRESSIM_CULLING");
  if (!v || !*v || std::strcmp(v, "1") == 0) return true;
  if (std::strcmp(v, "0") == 0) return false;
  throw std::invalid_argument(std::string("CRESSIM_CULLING='") + v + "': use 1 (cull) or 0 (draw every instance)");
}

Culling::Culling(std::shared_ptr<gpu::Context> ctx, const RenderModel& model, uint64_t generation,
                 compute::BufferMap& internal, const compute::BufferMap& bound) {
  std::vector<VkDrawIndexedIndirectCommand> commands;
  std::vector<uint32_t> instance_draws(model.instances.size());
  for (const auto& g : model.groups) {
    first_draw_.push_back(uint32_t(commands.size()));
    for (const auto& d : g.draws) {
      const MeshRange& m = model.meshes[d.mesh];
      for (uint32_t i = 0; i < d.instance_count; ++i) instance_draws[d.first_instance + i] = uint32_t(commands.size());
      commands.push_back({m.index_count, 0, m.first_index, m.vertex_offset, d.first_instance});
    }
  }
  command_bytes_ = std::max<size_t>(commands.size(), 1) * sizeof(VkDrawIndexedIndirectCommand);
  // the command buffer is also an indirect buffer, which keyed buffers are not made as
  commands_ = std::make_shared<compute::TypedBuffer>();
  commands_->key = "render.draw_commands";
  commands_->shape = {std::max<int64_t>(int64_t(commands.size()), 1), 5};
  commands_->dtype = DType::UINT32;
  commands_->read_only = true;
  commands_->generation = generation;
  commands_->storage = std::make_shared<gpu::OwnedBuffer>(
      ctx, command_bytes_, gpu::BufferOptions{gpu::Memory::DEVICE, VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT, false});
  internal[commands_->key] = commands_;
  template_ = std::make_unique<gpu::OwnedBuffer>(ctx, command_bytes_, gpu::BufferOptions{});
  if (!commands.empty())
    gpu::upload(*ctx, template_->buffer, commands.data(), commands.size() * sizeof(VkDrawIndexedIndirectCommand));

  std::vector<float> radii;
  for (const auto& m : model.meshes) radii.push_back(m.radius);
  const int64_t n = std::max<int64_t>(int64_t(model.instances.size()), 1);
  visible_instances_ = compute::make_keyed_buffer(ctx, internal, "render.visible_instances", std::vector<uint32_t>{},
                                                  {n, 2}, DType::UINT32, true, generation);
  visible_counts_ = compute::make_keyed_buffer(ctx, internal, "render.visible_counts", std::vector<uint32_t>{},
                                               {std::max<int64_t>(int64_t(model.cameras.size()), 1), 2}, DType::UINT32, true, generation);
  compute::BufferMap b{
      {"instances", bound.at("instances")},
      {"instance_draws", compute::make_keyed_buffer(ctx, internal, "render.instance_draws", instance_draws,
                                                    {n}, DType::UINT32, true, generation)},
      {"renderables", bound.at("renderables")},
      {"cameras", bound.at("cameras")},
      {"mesh_radii", compute::make_keyed_buffer(ctx, internal, "render.mesh_radii", radii,
                                                {std::max<int64_t>(int64_t(radii.size()), 1)}, DType::FLOAT32, true,
                                                generation)},
      {"positions", bound.at("positions")},
      {"rotations", bound.at("rotations")},
      {"scales", bound.at("scales")},
      {"draw_commands", commands_},
      {"visible_instances", visible_instances_},
      {"visible_counts", visible_counts_}};
  pass_ = compute::create_builtin_pass(ctx, "render/cull", b);
  const uint32_t count = uint32_t(model.instances.size()), enabled = culling_enabled() ? 1 : 0;
  pass_->set_constant_bits("count", &count, 4);
  pass_->set_constant_bits("enabled", &enabled, 4);
  pass_->set_groups({(count + 255) / 256, 1, 1});
}

void Culling::record(VkCommandBuffer cmd) const {
  const VkBufferCopy all{0, 0, command_bytes_};
  vkCmdCopyBuffer(cmd, template_->buffer.buffer, commands_->storage->buffer.buffer, 1, &all);
  vkCmdFillBuffer(cmd, visible_counts_->storage->buffer.buffer, 0, VK_WHOLE_SIZE, 0);
  gpu::compute_barrier(cmd);
  if (pass_->groups[0] > 0) pass_->record(cmd);
  gpu::compute_barrier(cmd);  // covers the indirect reads too (all commands, memory reads)
}

}  // namespace cressim::render
