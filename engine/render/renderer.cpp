#include "render/renderer.h"

#include <cstdlib>
#include <cstring>
#include <stdexcept>

#include "gpu/commands.h"
#include "gpu/context.h"
#include "gpu/embedded_shaders.h"
#include "gpu/graphics_pipeline.h"
#include "render/environment_map.h"

namespace cressim::render {
namespace {

using compute::DType;

constexpr VkFormat kColor = VK_FORMAT_R8G8B8A8_UNORM, kDepth = VK_FORMAT_R32_SFLOAT,
                   kSegmentation = VK_FORMAT_R32_UINT, kZ = VK_FORMAT_D32_SFLOAT;

template <class T>
std::shared_ptr<compute::TypedBuffer> make(std::shared_ptr<gpu::Context> ctx, BufferMap& into, const std::string& key,
                                           const std::vector<T>& data, std::vector<int64_t> shape, DType t,
                                           uint64_t generation, bool exportable = false) {
  return compute::make_keyed_buffer(std::move(ctx), into, key, data, std::move(shape), t, true, generation, exportable);
}

VkRenderingAttachmentInfo attachment(const gpu::Image& im, VkImageLayout layout, VkClearValue clear) {
  VkRenderingAttachmentInfo a{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  a.imageView = im.view;
  a.imageLayout = layout;
  a.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
  a.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  a.clearValue = clear;
  return a;
}

void copy_out(VkCommandBuffer cmd, const gpu::Image& im, const compute::TypedBuffer& out, VkDeviceSize offset = 0) {
  VkBufferImageCopy region{};
  region.bufferOffset = offset;
  region.imageSubresource = {gpu::aspect_of(im.format), 0, 0, im.layers};
  region.imageExtent = {im.width, im.height, 1};
  vkCmdCopyImageToBuffer(cmd, im.image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, out.storage->buffer.buffer, 1, &region);
}

}  // namespace

// CRESSIM_RASTER: "graphics", "compute", or "auto"/unset: compute on discrete GPUs (on an H100 it
// renders 64x64 cameras 19x faster than the graphics pipelines, which use a small part of the
// chip; benchmarks/README.md), graphics elsewhere (on a CPU, lavapipe, the reverse holds)
bool compute_raster(const gpu::Context& ctx) {
  const char* v = std::getenv("CRESSIM_RASTER");
  if (!v || !*v || std::strcmp(v, "auto") == 0) return ctx.info.type == "discrete";
  if (std::strcmp(v, "graphics") == 0) return false;
  if (std::strcmp(v, "compute") == 0) return true;
  throw std::invalid_argument(std::string("CRESSIM_RASTER='") + v + "': use 'auto', 'graphics' or 'compute'");
}

Renderer::Renderer(std::shared_ptr<gpu::Context> ctx, RenderModel model, uint64_t generation, BufferMap& internal,
                   const BufferMap& scene)
    : ctx_(std::move(ctx)), model_(std::move(model)) {
  const bool use_compute = compute_raster(*ctx_);
  const bool exportable = ctx_->external_memory_fd && !ctx_->unified_memory;
  auto n = [](const auto& v) { return int64_t(v.size()); };
  std::vector<uint32_t> flat_instances, flat_shadow_instances;
  for (auto& i : model_.instances) flat_instances.insert(flat_instances.end(), i.begin(), i.end());
  for (auto& i : model_.shadow_instances) flat_shadow_instances.insert(flat_shadow_instances.end(), i.begin(), i.end());
  const int64_t S = model_.shadow_resolution;
  shadow_maps_ = make(ctx_, internal, "render.shadow_maps", std::vector<float>{},
                      {std::max<int64_t>(model_.shadow_maps, 1), std::max<int64_t>(S, 1), std::max<int64_t>(S, 1)},
                      DType::FLOAT32, generation);
  BufferMap bound{
      {"vertex_positions", make(ctx_, internal, "render.vertex_positions", model_.vertex_positions,
                                {n(model_.vertex_positions), 4}, DType::FLOAT32, generation)},
      {"vertex_normals", make(ctx_, internal, "render.vertex_normals", model_.vertex_normals,
                              {n(model_.vertex_normals), 4}, DType::FLOAT32, generation)},
      {"instances", make(ctx_, internal, "render.instances", flat_instances, {n(model_.instances), 2}, DType::UINT32,
                         generation)},
      {"renderables", make(ctx_, internal, "render.renderables", model_.renderables,
                           {n(model_.renderables), int64_t(sizeof(shader::RenderableData) / 4)}, DType::UINT32, generation)},
      {"cameras", make(ctx_, internal, "render.cameras", model_.cameras,
                       {n(model_.cameras), int64_t(sizeof(shader::CameraData) / 4)}, DType::UINT32, generation)},
      {"vertex_uvs", make(ctx_, internal, "render.vertex_uvs", model_.vertex_uvs, {n(model_.vertex_positions), 2},
                          DType::FLOAT32, generation)},
      {"shadow_instances", make(ctx_, internal, "render.shadow_instances", flat_shadow_instances,
                                {std::max<int64_t>(n(model_.shadow_instances), 1), 2}, DType::UINT32, generation)},
      {"lights", make(ctx_, internal, "render.lights", model_.lights,
                      {n(model_.lights), int64_t(sizeof(shader::LightData) / 4)}, DType::FLOAT32, generation)},
      {"env_lighting", make(ctx_, internal, "render.env_lighting", model_.env_lighting,
                            {n(model_.env_lighting), int64_t(sizeof(shader::EnvLighting) / 4)}, DType::FLOAT32,
                            generation)},
      {"texture_infos", make(ctx_, internal, "render.textures", model_.textures,
                             {std::max<int64_t>(n(model_.textures), 1), 4}, DType::UINT32, generation)},
      {"texels", make(ctx_, internal, "render.texels", model_.texels, {std::max<int64_t>(n(model_.texels), 1)},
                      DType::UINT32, generation)},
      {"shadow_maps", shadow_maps_},
      {"positions", scene.at("transform.positions")},
      {"rotations", scene.at("transform.rotations")},
      {"scales", scene.at("transform.scales")}};
  build_environment_maps(ctx_, model_, generation, internal, bound);
  vertex_positions_ = bound.at("vertex_positions")->storage->buffer.buffer;
  particles_ = std::make_unique<ParticleDraw>(ctx_, model_, generation, internal, scene, bound);
  for (size_t k = 0; k < model_.meshes.size(); ++k) {
    const MeshRange& m = model_.meshes[k];
    if (m.positions_key.empty()) continue;
    auto it = scene.find(m.positions_key);
    if (it == scene.end())
      throw std::invalid_argument("mesh " + std::to_string(k) + ": positions_key '" + m.positions_key +
                                  "' is not an engine buffer (internal keys exist after upload_world())");
    const VkDeviceSize bytes = VkDeviceSize(m.vertex_count) * 16;
    if (it->second->bytes() < bytes)
      throw std::invalid_argument("mesh " + std::to_string(k) + ": positions_key '" + m.positions_key + "' holds " +
                                  std::to_string(it->second->bytes()) + " bytes; " + std::to_string(m.vertex_count) +
                                  " vertices need " + std::to_string(bytes) + " (float4 rows)");
    vertex_sources_.push_back({it->second, {0, VkDeviceSize(m.vertex_offset) * 16, bytes}});
  }
  indices_ = std::make_unique<gpu::OwnedBuffer>(
      ctx_, std::max<size_t>(model_.indices.size(), 1) * 4,
      gpu::BufferOptions{gpu::Memory::DEVICE, VK_BUFFER_USAGE_INDEX_BUFFER_BIT, false});
  gpu::upload(*ctx_, indices_->buffer, model_.indices.data(), model_.indices.size() * 4);

  culling_ = std::make_unique<Culling>(ctx_, model_, generation, internal, bound);
  VkPhysicalDeviceFeatures features{};  // enabled where present (gpu/context.cpp)
  vkGetPhysicalDeviceFeatures(ctx_->physical, &features);
  indirect_ = !use_compute && features.drawIndirectFirstInstance;
  multi_draw_ = features.multiDrawIndirect;
  if (!use_compute) {
    // a camera's unwanted products are attachments without an image view: their writes are dropped
    gpu::GraphicsPipelineDesc desc;
    desc.name = "render/raster";
    desc.vertex = &gpu::embedded_shader("render/raster.vert");
    desc.fragment = &gpu::embedded_shader("render/raster.frag");
    desc.color_formats = {kColor, kDepth, kSegmentation};
    desc.depth_format = kZ;
    pipeline_ = gpu::create_graphics_pipeline(*ctx_, desc);
    for (const auto& b : pipeline_.reflection.bindings) {
      // indirect draws: the instances are the culled list, each draw's at its first_instance
      const auto& buffer = indirect_ && b.name == "instances" ? culling_->visible_instances() : bound.at(b.name);
      gpu::bind_buffer(*ctx_, pipeline_, b.binding, buffer->storage->buffer.buffer);
    }
  }

  if (!model_.shadow_groups.empty()) {
    gpu::GraphicsPipelineDesc sd;
    sd.name = "render/shadow";
    sd.vertex = &gpu::embedded_shader("render/shadow.vert");
    sd.fragment = &gpu::embedded_shader("render/shadow.frag");
    sd.depth_format = kZ;
    shadow_pipeline_ = gpu::create_graphics_pipeline(*ctx_, sd);
    for (const auto& b : shadow_pipeline_.reflection.bindings)
      gpu::bind_buffer(*ctx_, shadow_pipeline_, b.binding, bound.at(b.name)->storage->buffer.buffer);
    for (const auto& g : model_.shadow_groups)
      shadow_targets_.push_back(gpu::create_image(*ctx_, kZ, uint32_t(S), uint32_t(S), g.layers,
                                                  VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT |
                                                      VK_IMAGE_USAGE_TRANSFER_SRC_BIT));
  }

  BufferMap compute_bound = bound;
  if (use_compute) {
    std::vector<std::array<uint32_t, 4>> ranges;
    for (const auto& m : model_.meshes) {
      uint32_t radius;
      std::memcpy(&radius, &m.radius, 4);
      ranges.push_back({m.first_index, m.index_count, uint32_t(m.vertex_offset), radius});
    }
    compute_bound["env_renderables"] = make(ctx_, internal, "render.env_renderables", model_.env_renderables,
                                            {n(model_.env_renderables), 2}, DType::UINT32, generation);
    compute_bound["mesh_ranges"] = make(ctx_, internal, "render.mesh_ranges", ranges, {n(ranges), 4}, DType::UINT32,
                                        generation);
    compute_bound["mesh_indices"] = make(ctx_, internal, "render.indices", model_.indices,
                                         {std::max<int64_t>(n(model_.indices), 1)}, DType::UINT32, generation);
  }
  // bound where a group does not write a product (its writes are skipped)
  compute_bound["unused_output"] = make(ctx_, internal, "render.unused_output", std::vector<uint32_t>{}, {1},
                                        DType::UINT32, generation);
  compute_bound["unused_depth"] = make(ctx_, internal, "render.unused_depth", std::vector<float>{}, {1},
                                       DType::FLOAT32, generation);

  const VkImageUsageFlags target = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  for (size_t g = 0; g < model_.groups.size(); ++g) {
    const auto& grp = model_.groups[g];
    const int64_t L = grp.layers, H = grp.height, W = grp.width;
    Targets t;
    const std::string prefix = "camera" + std::to_string(g) + ".";
    const bool rgb = grp.products & scene::PRODUCT_RGB, dep = grp.products & scene::PRODUCT_DEPTH,
               seg = grp.products & scene::PRODUCT_SEGMENTATION;
    if (rgb)
      t.rgb_out = make(ctx_, internal, prefix + "rgb", std::vector<uint8_t>{}, {L, H, W, 4}, DType::UINT8, generation,
                       exportable);
    if (dep)
      t.depth_out = make(ctx_, internal, prefix + "depth", std::vector<float>{}, {L, H, W}, DType::FLOAT32, generation,
                         exportable);
    if (seg)
      t.segmentation_out = make(ctx_, internal, prefix + "segmentation", std::vector<uint32_t>{}, {L, H, W},
                                DType::UINT32, generation, exportable);
    // fluids are composited over the scene's depth, a product or not
    t.scene_depth = t.depth_out;
    if (!dep && particles_->has_fluid())
      t.scene_depth = make(ctx_, internal, "render.group" + std::to_string(g) + "_scene_depth", std::vector<float>{},
                           {L, H, W}, DType::FLOAT32, generation);
    particles_->add_group(uint32_t(g),
                          {{"out_rgb", rgb ? t.rgb_out : compute_bound.at("unused_output")},
                           {"out_segmentation", seg ? t.segmentation_out : compute_bound.at("unused_output")},
                           {"scene_depth", t.scene_depth ? t.scene_depth : compute_bound.at("unused_depth")}},
                          grp.products);
    const uint32_t products = grp.products | (t.scene_depth ? uint32_t(scene::PRODUCT_DEPTH) : 0u);
    if (use_compute) {
      std::vector<uint32_t> by_layer(grp.layers);
      for (uint32_t c = 0; c < model_.cameras.size(); ++c)
        if (model_.cameras[c].ids.z == g) by_layer[model_.cameras[c].ids.w] = c;
      BufferMap b = compute_bound;
      b["group_cameras"] = make(ctx_, internal, "render.group" + std::to_string(g) + "_cameras", by_layer,
                                {int64_t(by_layer.size())}, DType::UINT32, generation);
      b["out_rgb"] = rgb ? t.rgb_out : compute_bound.at("unused_output");
      b["out_depth"] = t.scene_depth ? t.scene_depth : compute_bound.at("unused_depth");
      b["out_segmentation"] = seg ? t.segmentation_out : compute_bound.at("unused_output");
      auto pass = compute::create_builtin_pass(ctx_, "render/raster_compute", b);
      // a workgroup per camera and tile. 64 x 32 tiles, halved (to 16 x 16) while the group count
      // is below kRasterGroups: 32 cameras of 64 x 64 pixels were 64 groups, and the raster took
      // one group's latency with most SMs idle (TargetCenter, benchmarks/README.md)
      constexpr uint32_t kRasterGroups = 512;
      uint32_t shift_x = 6, shift_y = 5;
      const auto across = [](uint32_t pixels, uint32_t shift) { return (pixels + (1u << shift) - 1) >> shift; };
      const auto tiles = [&] { return across(grp.width, shift_x) * across(grp.height, shift_y); };
      while (uint64_t(tiles()) * grp.layers < kRasterGroups && (shift_x > 4 || shift_y > 4))
        --(shift_x >= shift_y ? shift_x : shift_y);
      pass->set_constant_bits("width", &grp.width, 4);
      pass->set_constant_bits("height", &grp.height, 4);
      pass->set_constant_bits("products", &products, 4);
      pass->set_constant_bits("tile_shift_x", &shift_x, 4);
      pass->set_constant_bits("tile_shift_y", &shift_y, 4);
      pass->set_groups({tiles(), grp.layers, 1});
      compute_passes_.push_back(pass);
      targets_.push_back(std::move(t));
      continue;
    }
    if (rgb) t.color = gpu::create_image(*ctx_, kColor, grp.width, grp.height, grp.layers, target);
    if (t.scene_depth) t.depth = gpu::create_image(*ctx_, kDepth, grp.width, grp.height, grp.layers, target);
    if (seg) t.segmentation = gpu::create_image(*ctx_, kSegmentation, grp.width, grp.height, grp.layers, target);
    t.z_buffer = gpu::create_image(*ctx_, kZ, grp.width, grp.height, grp.layers, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT);
    targets_.push_back(std::move(t));
  }
}

Renderer::~Renderer() {
  for (auto& t : targets_)
    for (gpu::Image* im : {&t.color, &t.depth, &t.segmentation, &t.z_buffer}) gpu::destroy_image(*ctx_, *im);
  for (auto& im : shadow_targets_) gpu::destroy_image(*ctx_, im);
  if (pipeline_.pipeline) gpu::destroy_compute_pipeline(*ctx_, pipeline_);
  if (shadow_pipeline_.pipeline) gpu::destroy_compute_pipeline(*ctx_, shadow_pipeline_);
}

void Renderer::record_shadows(VkCommandBuffer cmd) const {
  const uint32_t S = model_.shadow_resolution;
  for (size_t g = 0; g < model_.shadow_groups.size(); ++g) {
    const auto& grp = model_.shadow_groups[g];
    const gpu::Image& target = shadow_targets_[g];
    gpu::image_barrier(cmd, target, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL);
    VkClearValue far_plane{};
    far_plane.depthStencil.depth = 1.0f;
    VkRenderingAttachmentInfo depth = attachment(target, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, far_plane);
    VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
    ri.renderArea = {{0, 0}, {S, S}};
    ri.layerCount = grp.layers;
    ri.pDepthAttachment = &depth;
    vkCmdBeginRendering(cmd, &ri);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, shadow_pipeline_.pipeline);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, shadow_pipeline_.layout, 0, 1, &shadow_pipeline_.set,
                            0, nullptr);
    vkCmdBindIndexBuffer(cmd, indices_->buffer.buffer, 0, VK_INDEX_TYPE_UINT32);
    const VkViewport viewport{0, 0, float(S), float(S), 0, 1};
    const VkRect2D scissor{{0, 0}, {S, S}};
    vkCmdSetViewport(cmd, 0, 1, &viewport);
    vkCmdSetScissor(cmd, 0, 1, &scissor);
    for (const auto& d : grp.draws) {
      const MeshRange& m = model_.meshes[d.mesh];
      vkCmdDrawIndexed(cmd, m.index_count, d.instance_count, m.first_index, m.vertex_offset, d.first_instance);
    }
    vkCmdEndRendering(cmd);
    gpu::image_barrier(cmd, target, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
    copy_out(cmd, target, *shadow_maps_, VkDeviceSize(grp.first_map) * S * S * 4);
  }
  if (!model_.shadow_groups.empty()) gpu::compute_barrier(cmd);  // the camera passes read the maps
}

void Renderer::record(VkCommandBuffer cmd) const {
  for (const auto& v : vertex_sources_)
    vkCmdCopyBuffer(cmd, v.from->storage->buffer.buffer, vertex_positions_, 1, &v.region);
  if (!vertex_sources_.empty()) gpu::compute_barrier(cmd);
  particles_->record_vertices(cmd);
  record_shadows(cmd);
  culling_->record(cmd);
  for (size_t g = 0; g < compute_passes_.size(); ++g) {
    compute_passes_[g]->record(cmd);
    particles_->record_fluid(cmd, uint32_t(g));
  }
  for (size_t g = 0; g < model_.groups.size() && compute_passes_.empty(); ++g) {
    const auto& grp = model_.groups[g];
    const Targets& t = targets_[g];
    for (const gpu::Image* im : {&t.color, &t.depth, &t.segmentation})
      if (im->image) gpu::image_barrier(cmd, *im, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL);
    gpu::image_barrier(cmd, t.z_buffer, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL);
    VkClearValue background{}, black{}, far_plane{};
    black.color.float32[3] = 1.0f;  // opaque
    far_plane.depthStencil.depth = 1.0f;
    VkRenderingAttachmentInfo colors[3] = {
        attachment(t.color, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, black),
        attachment(t.depth, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, background),
        attachment(t.segmentation, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, background)};
    VkRenderingAttachmentInfo depth = attachment(t.z_buffer, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, far_plane);
    depth.storeOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
    VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
    ri.renderArea = {{0, 0}, {grp.width, grp.height}};
    ri.layerCount = grp.layers;
    ri.colorAttachmentCount = 3;
    ri.pColorAttachments = colors;
    ri.pDepthAttachment = &depth;
    vkCmdBeginRendering(cmd, &ri);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline_.pipeline);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline_.layout, 0, 1, &pipeline_.set, 0, nullptr);
    vkCmdBindIndexBuffer(cmd, indices_->buffer.buffer, 0, VK_INDEX_TYPE_UINT32);
    const VkViewport viewport{0, 0, float(grp.width), float(grp.height), 0, 1};
    const VkRect2D scissor{{0, 0}, {grp.width, grp.height}};
    vkCmdSetViewport(cmd, 0, 1, &viewport);
    vkCmdSetScissor(cmd, 0, 1, &scissor);
    const uint32_t draws = uint32_t(grp.draws.size());
    const VkDeviceSize first = VkDeviceSize(culling_->first_draw(g)) * sizeof(VkDrawIndexedIndirectCommand);
    if (indirect_ && multi_draw_) {
      if (draws) vkCmdDrawIndexedIndirect(cmd, culling_->commands(), first, draws, sizeof(VkDrawIndexedIndirectCommand));
    } else if (indirect_) {
      for (uint32_t d = 0; d < draws; ++d)
        vkCmdDrawIndexedIndirect(cmd, culling_->commands(), first + d * sizeof(VkDrawIndexedIndirectCommand), 1, 0);
    } else {
      for (const auto& d : grp.draws) {
        const MeshRange& m = model_.meshes[d.mesh];
        vkCmdDrawIndexed(cmd, m.index_count, d.instance_count, m.first_index, m.vertex_offset, d.first_instance);
      }
    }
    vkCmdEndRendering(cmd);
    for (const gpu::Image* im : {&t.color, &t.depth, &t.segmentation})
      if (im->image) gpu::image_barrier(cmd, *im, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL);
    if (t.rgb_out) copy_out(cmd, t.color, *t.rgb_out);
    if (t.scene_depth) copy_out(cmd, t.depth, *t.scene_depth);
    if (t.segmentation_out) copy_out(cmd, t.segmentation, *t.segmentation_out);
    particles_->record_fluid(cmd, uint32_t(g));
  }
}

}  // namespace cressim::render
