#include "render/particle_draw.h"

#include "cressim/particle.h"
#include "gpu/commands.h"

namespace cressim::render {
namespace {

using compute::DType;

int64_t rows(size_t n) { return std::max<int64_t>(int64_t(n), 1); }

}  // namespace

ParticleDraw::ParticleDraw(std::shared_ptr<gpu::Context> ctx, const RenderModel& model, uint64_t generation,
                           BufferMap& internal, const BufferMap& scene, const BufferMap& bound)
    : ctx_(std::move(ctx)), model_(model), generation_(generation), internal_(internal), bound_(bound) {
  if (!scene.count("particles.positions")) return;
  auto make = [&](const std::string& key, const auto& data, int64_t width, DType t) {
    std::vector<int64_t> shape{rows(data.size())};
    if (width > 1) shape.push_back(width);
    return compute::make_keyed_buffer(ctx_, internal_, key, data, shape, t, true, generation_);
  };
  bound_["particle_positions"] = scene.at("particles.positions");
  bound_["particle_phases"] = scene.at("particles.phases");
  bound_["particle_objects"] = scene.at("particles.objects");
  bound_["particle_orientations"] = scene.at("particles.orientations");
  bound_["particle_damage"] = scene.at("particles.damage");
  bound_["recipes"] = make("render.particle_vertices", model_.particle_vertices, 4, DType::UINT32);
  bound_["adjacency"] = make("render.particle_adjacency", model_.particle_adjacency, 1, DType::UINT32);
  bound_["triangles"] = make("render.particle_triangles", model_.particle_triangles, 4, DType::UINT32);
  bound_["fluid_looks"] = make("render.fluid_looks", model_.fluid_looks, int64_t(sizeof(shader::RenderableData) / 4),
                               DType::UINT32);
  has_fluid_ = model_.has_fluid;
  if (model_.particle_vertices.empty()) return;  // fluids only
  vertices_ = compute::create_builtin_pass(ctx_, "render/particle_vertices", bound_);
  const uint32_t count = uint32_t(model_.particle_vertices.size()), base = model_.particle_vertex_base;
  vertices_->set_constant_bits("count", &count, 4);
  vertices_->set_constant_bits("base", &base, 4);
  vertices_->set_threads({count, 1, 1});
}

void ParticleDraw::add_group(uint32_t group, const BufferMap& outputs, uint32_t products) {
  if (fluid_.size() <= group) fluid_.resize(group + 1);
  if (!has_fluid_) return;
  const auto& grp = model_.groups[group];
  const std::string prefix = "render.fluid" + std::to_string(group) + ".";
  // this group's cameras, env by env, and per layer
  const uint32_t envs = uint32_t(model_.fluid_looks.size());
  std::vector<std::vector<uint32_t>> by_env(envs);
  std::vector<uint32_t> by_layer(grp.layers), layer_cameras;
  for (uint32_t c = 0; c < model_.cameras.size(); ++c)
    if (model_.cameras[c].ids.z == group) {
      by_env[model_.cameras[c].ids.y].push_back(c);
      by_layer[model_.cameras[c].ids.w] = c;
    }
  std::vector<std::array<uint32_t, 2>> env_layers;
  for (const auto& cams : by_env) {
    env_layers.push_back({uint32_t(layer_cameras.size()), uint32_t(cams.size())});
    layer_cameras.insert(layer_cameras.end(), cams.begin(), cams.end());
  }
  const std::vector<int64_t> pixels{grp.layers, grp.height, grp.width};
  FluidGroup& f = fluid_[group];
  f.depth = compute::make_keyed_buffer(ctx_, internal_, prefix + "depth", std::vector<uint32_t>{}, pixels,
                                       DType::UINT32, true, generation_);
  f.thickness = compute::make_keyed_buffer(ctx_, internal_, prefix + "thickness", std::vector<uint32_t>{}, pixels,
                                           DType::UINT32, true, generation_);
  BufferMap b = bound_;
  b.insert(outputs.begin(), outputs.end());
  b["env_layers"] = compute::make_keyed_buffer(ctx_, internal_, prefix + "env_layers", env_layers,
                                               {int64_t(envs), 2}, DType::UINT32, true, generation_);
  b["layer_cameras"] = compute::make_keyed_buffer(ctx_, internal_, prefix + "layer_cameras", layer_cameras,
                                                  {rows(layer_cameras.size())}, DType::UINT32, true, generation_);
  b["group_cameras"] = compute::make_keyed_buffer(ctx_, internal_, prefix + "group_cameras", by_layer,
                                                  {int64_t(grp.layers)}, DType::UINT32, true, generation_);
  b["fluid_depth"] = f.depth;
  b["fluid_thickness"] = f.thickness;
  auto pixel_buffer = [&](const std::string& name) {
    return compute::make_keyed_buffer(ctx_, internal_, prefix + name, std::vector<uint32_t>{}, pixels, DType::UINT32,
                                      true, generation_);
  };
  // the separable filter: along rows into "blurred", along columns into "smoothed"
  b["fluid_smoothed"] = pixel_buffer("smoothed");
  b["fluid_smoothed_thickness"] = pixel_buffer("smoothed_thickness");
  BufferMap by_rows = b, by_columns = b;
  by_rows["depth_in"] = f.depth;
  by_rows["thickness_in"] = f.thickness;
  by_rows["depth_out"] = by_columns["depth_in"] = pixel_buffer("blurred");
  by_rows["thickness_out"] = by_columns["thickness_in"] = pixel_buffer("blurred_thickness");
  by_columns["depth_out"] = b["fluid_smoothed"];
  by_columns["thickness_out"] = b["fluid_smoothed_thickness"];
  const uint32_t particles = uint32_t(bound_.at("particle_positions")->shape[0]);
  f.splat = compute::create_builtin_pass(ctx_, "render/fluid_splat", b);
  f.smooth_rows = compute::create_builtin_pass(ctx_, "render/fluid_smooth", by_rows);
  f.smooth_columns = compute::create_builtin_pass(ctx_, "render/fluid_smooth", by_columns);
  f.shade = compute::create_builtin_pass(ctx_, "render/fluid_shade", b);
  for (auto& pass : {f.splat, f.smooth_rows, f.smooth_columns, f.shade}) {
    pass->set_constant_bits("width", &grp.width, 4);
    pass->set_constant_bits("height", &grp.height, 4);
    pass->set_constant_bits("layers", &grp.layers, 4);
  }
  const uint32_t along_rows = 0, along_columns = 1;
  f.smooth_rows->set_constant_bits("axis", &along_rows, 4);
  f.smooth_columns->set_constant_bits("axis", &along_columns, 4);
  f.splat->set_constant_bits("particle_count", &particles, 4);
  f.shade->set_constant_bits("products", &products, 4);
  f.splat->set_threads({particles, 1, 1});
  f.smooth_rows->set_threads({grp.width, grp.height, grp.layers});
  f.smooth_columns->set_threads({grp.width, grp.height, grp.layers});
  f.shade->set_threads({grp.width, grp.height, grp.layers});
}

void ParticleDraw::record_vertices(VkCommandBuffer cmd) const {
  if (!vertices_) return;
  vertices_->record(cmd);
  gpu::compute_barrier(cmd);
}

void ParticleDraw::record_fluid(VkCommandBuffer cmd, uint32_t group) const {
  if (group >= fluid_.size() || !fluid_[group].splat) return;
  const FluidGroup& f = fluid_[group];
  gpu::compute_barrier(cmd);  // the group's outputs are written
  vkCmdFillBuffer(cmd, f.depth->storage->buffer.buffer, 0, VK_WHOLE_SIZE, 0xffffffffu);
  vkCmdFillBuffer(cmd, f.thickness->storage->buffer.buffer, 0, VK_WHOLE_SIZE, 0);
  gpu::compute_barrier(cmd);
  f.splat->record(cmd);
  gpu::compute_barrier(cmd);
  f.smooth_rows->record(cmd);
  gpu::compute_barrier(cmd);
  f.smooth_columns->record(cmd);
  gpu::compute_barrier(cmd);
  f.shade->record(cmd);
}

}  // namespace cressim::render
