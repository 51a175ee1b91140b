#include "render/environment_map.h"

#include <algorithm>

#include "compute/compute_pass.h"
#include "cressim/ibl.h"
#include "gpu/commands.h"

namespace cressim::render {

using compute::DType;

void build_environment_maps(std::shared_ptr<gpu::Context> ctx, const RenderModel& model, uint64_t generation,
                            compute::BufferMap& internal, compute::BufferMap& bound) {
  const uint32_t slots = uint32_t(model.environment_maps.size());
  const int64_t n = std::max<int64_t>(slots, 1);
  auto make = [&](const std::string& key, std::vector<int64_t> shape) {
    return compute::make_keyed_buffer(ctx, internal, key, std::vector<float>{}, std::move(shape), DType::FLOAT32, true,
                                      generation);
  };
  bound["ibl_sh"] = make("render.ibl_sh", {n, shader::IBL_SH, 4});
  bound["ibl_specular"] = make("render.ibl_specular", {n, shader::IBL_LEVELS, shader::IBL_SPEC_H, shader::IBL_SPEC_W, 4});
  if (slots == 0) return;
  auto grid = make("render.ibl_grid", {n, shader::IBL_GRID_H, shader::IBL_GRID_W, 4});
  auto maps = compute::make_keyed_buffer(ctx, internal, "render.environment_maps", model.environment_maps, {n, 4},
                                         DType::FLOAT32, true, generation);
  auto to_grid = compute::create_builtin_pass(
      ctx, "render/ibl_grid",
      {{"texture_infos", bound.at("texture_infos")}, {"texels", bound.at("texels")}, {"ibl_slots", maps},
       {"ibl_grid", grid}});
  to_grid->set_groups({(shader::IBL_GRID_W * shader::IBL_GRID_H + 63) / 64, slots, 1});
  auto sh = compute::create_builtin_pass(ctx, "render/ibl_sh", {{"ibl_grid", grid}, {"ibl_sh", bound.at("ibl_sh")}});
  sh->set_groups({slots, 1, 1});
  auto specular = compute::create_builtin_pass(ctx, "render/ibl_specular",
                                               {{"ibl_grid", grid}, {"ibl_specular", bound.at("ibl_specular")}});
  specular->set_groups({(shader::IBL_SPEC_W * shader::IBL_SPEC_H + 63) / 64, shader::IBL_LEVELS, slots});
  gpu::submit_now(*ctx, [&](VkCommandBuffer cmd) {
    to_grid->record(cmd);
    gpu::compute_barrier(cmd);
    sh->record(cmd);
    specular->record(cmd);
  });
}

}  // namespace cressim::render
