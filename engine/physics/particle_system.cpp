#include "physics/particle_system.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstring>

#include "gpu/commands.h"
#include "cressim/layout.h"
#include "gpu/context.h"
#include "gpu/embedded_shaders.h"
#include "gpu/spirv_reflect.h"

namespace cressim::physics {
namespace {

// The `<shader>.blockN` build (cmake/shaders.cmake) with the least group memory that holds
// `particles` an env within the device's group memory, or "" where none does (the passes then
// dispatch a colour at a time). Group memory sets how many workgroups share a multiprocessor:
// SoftBodyPush's 343-particle envs in 1,024-particle groups ran three a multiprocessor and took
// 9.0 instead of 5.9 ms a frame for their solves at 512 envs (H200).
std::string block_build(const gpu::Context& ctx, const std::vector<std::string>& shaders, const std::string& shader,
                        uint32_t particles) {
  const std::string prefix = shader + ".block";
  std::string best;
  unsigned long best_capacity = ~0ul;
  for (const auto& name : shaders) {
    if (name.size() <= prefix.size() || name.compare(0, prefix.size(), prefix) != 0) continue;
    const unsigned long capacity = std::stoul(name.substr(prefix.size()));
    if (capacity < particles || capacity >= best_capacity) continue;
    if (gpu::reflect_spirv(gpu::embedded_shader(name)).workgroup_bytes > ctx.properties.limits.maxComputeSharedMemorySize)
      continue;
    best = name, best_capacity = capacity;
  }
  return best;
}

using compute::DType;
using shader::float4;
using shader::uint4;

// a pass's item_offset and item_count (ParticleConstants), set as it is recorded
void put(compute::ComputePass& p, uint32_t offset, uint32_t count) {
  std::memcpy(p.constants.data() + offsetof(shader::ParticleConstants, item_offset), &offset, 4);
  std::memcpy(p.constants.data() + offsetof(shader::ParticleConstants, item_count), &count, 4);
}

// The workgroup solve's copy of a family's records (PARTICLE_BLOCK_NONE in cressim/particle.h
// says the layout): each record's particles as indices into the env whose slice of
// `env_colours` holds it, and its rest value and compliance as authored (particle_block_pack
// refreshes those each frame).
std::vector<uint4> block_records(const ConstraintSet& s, const std::vector<shader::ParticleEnvRange>& envs) {
  std::vector<uint4> rows(s.records.size(), uint4{shader::PARTICLE_BLOCK_NONE * 0x10001u, shader::PARTICLE_BLOCK_NONE * 0x10001u, 0, 0});
  const size_t colours = s.colour_count.size();
  for (size_t e = 0; e < envs.size(); ++e) {
    const uint32_t first = envs[e].range.x, count = envs[e].range.y;
    for (size_t k = 0; k < colours; ++k) {
      const uint32_t begin = s.env_colours[2 * (e * colours + k)], n = s.env_colours[2 * (e * colours + k) + 1];
      for (uint32_t c = begin; c < begin + n; ++c) {
        const auto& rec = s.records[c];
        const uint32_t ids[4] = {rec.particles.x, rec.particles.y, rec.particles.z, rec.particles.w};
        uint32_t local[4];
        for (int m = 0; m < 4; ++m) {
          if (ids[m] == shader::CRESSIM_NONE) { local[m] = shader::PARTICLE_BLOCK_NONE; continue; }
          if (ids[m] < first || ids[m] - first >= count)
            throw std::logic_error("particle family '" + s.name + "': record " + std::to_string(c) + " of env " +
                                   std::to_string(e) + " has particle " + std::to_string(ids[m]) + " outside the env");
          local[m] = ids[m] - first;
        }
        float params[2] = {rec.params.x, rec.params.y};
        uint32_t bits[2];
        std::memcpy(bits, params, sizeof(bits));
        rows[c] = uint4{local[0] | local[1] << 16, local[2] | local[3] << 16, bits[0], bits[1]};
      }
    }
  }
  return rows;
}

constexpr uint32_t kScanBlock = 256;  // particle_scan_*.comp.hlsl group size
constexpr uint32_t kGroup = shader::CRESSIM_GROUP_SIZE;

template <class T>
std::vector<uint32_t> words(const std::vector<T>& v) {
  std::vector<uint32_t> w(v.size() * sizeof(T) / 4);
  if (!v.empty()) std::memcpy(w.data(), v.data(), w.size() * 4);
  return w;
}

uint32_t next_pow2(uint64_t n) {
  uint32_t p = 1;
  while (p < n) p <<= 1;
  return p;
}

}  // namespace

ParticleSystem::ParticleSystem(std::shared_ptr<gpu::Context> ctx, ParticleModel model, const PhysicsSettings& settings,
                               uint64_t generation, BufferMap& internal, BufferMap& control, const BufferMap& scene,
                               bool has_rigid, bool dynamic_bodies)
    : ctx_(ctx), model_(std::move(model)), settings_(settings), has_rigid_(has_rigid),
      attachments_per_env_(settings.max_particle_attachments_per_env) {
  const auto n = int64_t(model_.size()), no = int64_t(model_.objects.size()), ne = int64_t(model_.env_ranges.size());
  const bool exportable = ctx->external_memory_fd && !ctx->unified_memory;
  // a few buckets per particle keeps buckets short; at least one scan block
  table_size_ = next_pow2(std::max<uint64_t>(2 * uint64_t(n), kScanBlock));
  blocks_ = table_size_ / kScanBlock;

  auto make = [&](BufferMap& into, const std::string& key, const void* data, size_t bytes, std::vector<int64_t> shape,
                  DType t, bool read_only, bool exp) {
    return compute::make_keyed_buffer(ctx, into, key, data, bytes, std::move(shape), t, read_only, generation, exp);
  };
  // internal buffer `key`, bound in the passes as `hlsl`
  auto in = [&](const std::string& hlsl, const std::string& key, const auto& data, std::vector<int64_t> shape, DType t,
                bool exp = false) {
    using V = std::decay_t<decltype(data)>;
    const void* p = data.empty() ? nullptr : static_cast<const void*>(data.data());
    auto b = make(internal, key, p, data.size() * sizeof(typename V::value_type), std::move(shape), t, true, exp);
    if (!hlsl.empty()) bindings_[hlsl] = b;
    return b;
  };
  auto scratch = [&](const std::string& hlsl, const std::string& key, std::vector<int64_t> shape, DType t) {
    auto b = make(internal, key, nullptr, 0, std::move(shape), t, true, false);
    bindings_[hlsl] = b;
    return b;
  };
  const std::vector<uint32_t> none;

  // state and model (read-only to custom passes)
  in("positions", "particles.positions", model_.positions, {n, 4}, DType::FLOAT32, exportable);
  in("velocities", "particles.velocities", model_.velocities, {n, 4}, DType::FLOAT32, exportable);
  in("phases", "particles.phases", model_.phases, {n, 4}, DType::UINT32, exportable);
  in("initial_positions", "particles.initial_positions", model_.positions, {n, 4}, DType::FLOAT32);
  in("initial_velocities", "particles.initial_velocities", model_.velocities, {n, 4}, DType::FLOAT32);
  in("initial_phases", "particles.initial_phases", model_.phases, {n, 4}, DType::UINT32);
  in("objects", "particles.objects", words(model_.objects), {no, int64_t(sizeof(shader::ParticleObject) / 4)}, DType::UINT32);
  in("env_ranges", "particles.env_ranges", words(model_.env_ranges), {ne, 4}, DType::UINT32);
  const auto ne_ = int64_t(model_.orientations.size());
  in("orientations", "particles.orientations", model_.orientations, {ne_, 4}, DType::FLOAT32, exportable);
  in("initial_orientations", "particles.initial_orientations", model_.orientations, {ne_, 4}, DType::FLOAT32);
  in("orientation_weights", "particles.orientation_weights", model_.orientation_weights, {ne_}, DType::FLOAT32);
  in("edge_particles", "particles.edge_particles", model_.edge_particles, {ne_}, DType::UINT32);
  scratch("prev_orientations", "particles.prev_orientations", {ne_, 4}, DType::FLOAT32);
  scratch("angular_velocities", "particles.angular_velocities", {ne_, 4}, DType::FLOAT32);
  std::vector<uint32_t> active(static_cast<size_t>(no), 0u);
  for (size_t o = 0; o < active.size(); ++o) active[o] = model_.objects[o].range.w == shader::PARTICLE_FLUID ? model_.objects[o].ids.w : model_.objects[o].range.y;
  in("emitted", "particles.emitted", active, {no}, DType::UINT32);
  in("first_free", "particles.first_free", active, {no}, DType::UINT32);
  in("surface", "particles.surface", model_.surface, {int64_t(model_.surface.size() / 3), 3}, DType::UINT32);
  scratch("densities", "particles.densities", {n}, DType::FLOAT32);
  // scratch
  // elastic bodies: the share of a substep's fall their last solve held back (particle_tet_support)
  in("object_supports", "particles.object_supports", std::vector<float>(size_t(no), 0.f), {no}, DType::FLOAT32);
  scratch("prev_positions", "particles.prev_positions", {n, 4}, DType::FLOAT32);
  scratch("deltas", "particles.deltas", {n, 4}, DType::FLOAT32);
  scratch("fluid_lambdas", "particles.fluid_lambdas", {n}, DType::FLOAT32);
  scratch("wall_gradients", "particles.wall_gradients", {model_.has_fluid ? n : 1, 4}, DType::FLOAT32);
  scratch("vorticities", "particles.vorticities", {n, 4}, DType::FLOAT32);
  scratch("normals", "particles.normals", {n, 4}, DType::FLOAT32);
  scratch("velocity_copies", "particles.velocity_copies", {n, 4}, DType::FLOAT32);
  scratch("rigid_pushes", "particles.rigid_pushes", {n, 4}, DType::FLOAT32);
  scratch("rigid_contacts", "particles.rigid_contacts", {n, 4}, DType::FLOAT32);
  scratch("collider_near", "particles.collider_near", {has_rigid_ ? n : 1}, DType::UINT32);
  // out: the force each particle exerts on a body (N, world, frame average; w body + 1, 0: none)
  in("rigid_forces", "particles.rigid_forces", std::vector<float4>(size_t(n), float4{0, 0, 0, 0}), {n, 4},
     DType::FLOAT32, exportable);
  frame_clear_ = bindings_.at("rigid_forces")->storage->buffer.buffer;
  // elastic particles: the elastic solve's contact forces on kinematic bodies (its last iteration)
  const auto* tets = model_.set("tet");
  const bool elastic = tets && !tets->records.empty();
  scratch("tet_contact_forces", "particles.tet_contact_forces", {elastic ? n : 1, 4}, DType::FLOAT32);
  scratch("cells", "particles.cells", {n, 4}, DType::INT32);
  scratch("buckets", "particles.buckets", {n}, DType::UINT32);
  scratch("sorted", "particles.sorted", {n}, DType::UINT32);
  auto counts = scratch("cell_counts", "particles.cell_counts", {int64_t(table_size_)}, DType::UINT32);
  scratch("cell_starts", "particles.cell_starts", {int64_t(table_size_)}, DType::UINT32);
  auto fill = scratch("cell_fill", "particles.cell_fill", {int64_t(table_size_)}, DType::UINT32);
  scratch("block_sums", "particles.block_sums", {int64_t(blocks_)}, DType::UINT32);
  const bool grid = model_.has_fluid || model_.has_contacts;
  scratch("neighbor_counts", "particles.neighbor_counts", {n}, DType::UINT32);
  scratch("neighbor_lists", "particles.neighbor_lists", {grid ? int64_t(shader::PARTICLE_MAX_NEIGHBORS) : 1, n},
          DType::UINT32);
  if (grid) grid_clears_ = {counts->storage->buffer.buffer, fill->storage->buffer.buffer};

  // control: attachment slots, all free
  const int64_t na = ne * int64_t(attachments_per_env_);
  std::vector<shader::ParticleAttachment> att(size_t(na), shader::ParticleAttachment{});
  for (int64_t a = 0; a < na; ++a) att[size_t(a)].ids = {0, 0, shader::ATTACH_FREE, uint32_t(a / std::max<uint32_t>(attachments_per_env_, 1))};
  bindings_["attachments"] = make(control, "control.particle_attachments", att.data(), att.size() * sizeof(att[0]),
                                  {na, int64_t(sizeof(shader::ParticleAttachment) / 4)}, DType::UINT32, false, exportable);

  // control: fluid removal flags, applied at the next step's start (particle_remove.comp.hlsl)
  const std::vector<uint32_t> keep(size_t(n), 0u);
  bindings_["remove_flags"] = make(control, "control.particle_remove", keep.data(), keep.size() * 4, {n}, DType::UINT32,
                                   false, false);

  // control: one fluid sink per env (particle_integrate.comp.hlsl), all off
  const std::vector<float4> no_sinks(size_t(2 * ne), float4{0, 0, 0, 0});
  bindings_["fluid_sinks"] = make(control, "control.fluid_sinks", no_sinks.data(), no_sinks.size() * sizeof(float4),
                                  {ne, 2, 4}, DType::FLOAT32, false, false);

  // control: an external force on each particle (N, world; particle_integrate.comp.hlsl), none
  const std::vector<float4> no_forces(size_t(n), float4{0, 0, 0, 0});
  bindings_["particle_forces"] = make(control, "control.particle_forces", no_forces.data(),
                                      no_forces.size() * sizeof(float4), {n, 4}, DType::FLOAT32, false, false);

  // tendons (scene::Tendons; particle_tendon.comp.hlsl): each held at its rest length until driven
  if (!model_.tendons.empty()) {
    const auto nt = int64_t(model_.tendons.size()), nr = int64_t(model_.tendon_robots.size());
    in("tendon_robots", "particles.tendon_robots", words(model_.tendon_robots), {nr, 4}, DType::UINT32);
    in("tendon_disks", "particles.tendon_disks", model_.tendon_disks, {int64_t(model_.tendon_disks.size() / 2), 2}, DType::UINT32);
    in("tendons", "particles.tendons", words(model_.tendons), {nt, int64_t(sizeof(shader::Tendon) / 4)}, DType::UINT32);
    std::vector<float> hold(size_t(2 * nt), 0.f);
    for (int64_t t = 0; t < nt; ++t) hold[size_t(2 * t)] = float(shader::TENDON_DISPLACEMENT);
    bindings_["tendon_commands"] = make(control, "control.tendon_commands", hold.data(), hold.size() * 4, {nt, 2},
                                        DType::FLOAT32, false, false);
    in("tendon_states", "particles.tendon_states", std::vector<float4>(size_t(nt), float4{0, 0, 0, 0}), {nt, 4},
       DType::FLOAT32);
    auto lambdas = scratch("tendon_lambdas", "particles.tendon_lambdas", {nt}, DType::FLOAT32);
    per_substep_clears_.push_back(lambdas->storage->buffer.buffer);
  }

  // suture needles (scene::Needle; particle_needle_*.comp.hlsl): puncture records, all free, and
  // their grip on the tissue for the elastic solve (cleared each substep), or a stand-in
  scratch("tet_pins", "particles.tet_pins", {model_.needles.empty() ? 1 : n, 4}, DType::FLOAT32);
  if (!model_.needles.empty()) {
    per_substep_clears_.push_back(bindings_.at("tet_pins")->storage->buffer.buffer);
    const auto nn = int64_t(model_.needles.size()), nr = int64_t(model_.puncture_records);
    in("needles", "particles.needles", words(model_.needles), {nn, int64_t(sizeof(shader::NeedleModel) / 4)}, DType::UINT32);
    in("punctures", "particles.punctures", std::vector<shader::Puncture>(size_t(nr), shader::Puncture{}),
       {nr, int64_t(sizeof(shader::Puncture) / 4)}, DType::UINT32);
    in("needle_states", "particles.needle_states", std::vector<float4>(size_t(nn), float4{0, 0, 0, -1}), {nn, 4},
       DType::FLOAT32);
    // per needle: the taut thread's tension (N) and its way from the tail (particle_needle_solve)
    in("needle_threads", "particles.needle_threads", std::vector<float4>(size_t(nn), float4{0, 0, 0, 0}), {nn, 4},
       DType::FLOAT32);
    // per needle: the body that holds it (its row + 1; 0: none), which bears its load (particle_needle_load)
    const std::vector<uint32_t> free_(size_t(nn), 0u);
    bindings_["needle_holders"] = make(control, "control.needle_holders", free_.data(), free_.size() * 4, {nn},
                                       DType::UINT32, false, exportable);
  }

  // env flags, shared with the rigid solver; made here when there is none
  for (const char* k : {"env.reset_mask", "env.health", "env.health_events"})
    if (scene.count(k)) bindings_[k + 4] = scene.at(k);
  if (!bindings_.count("health")) bindings_["health"] = make(internal, "env.health", nullptr, 0, {ne}, DType::UINT32, true, exportable);
  if (!bindings_.count("health_events")) {
    auto events = compute::make_typed_buffer(ctx, "env.health_events", {1}, DType::UINT32, true, false, gpu::Memory::READBACK);
    events->generation = generation;
    gpu::fill(*ctx, events->storage->buffer, 0);
    internal["env.health_events"] = events;
    bindings_["health_events"] = events;
  }
  // rigid colliders and bodies, or one-element stand-ins of the element the passes declare
  struct Rigid {
    const char *hlsl, *key;
    int64_t words;  // 4-byte words an element
    DType type;
  };
  const Rigid rigid[] = {
      {"env_rigid_ranges", "rigid.env_ranges", sizeof(shader::EnvRigidRange) / 4, DType::UINT32},
      {"colliders", "rigid.colliders", sizeof(shader::ColliderModel) / 4, DType::UINT32},
      {"bodies", "rigid.bodies", sizeof(shader::BodyModel) / 4, DType::UINT32},
      {"body_dynamic_inertia", "rigid.dynamic_inertia", 4, DType::FLOAT32},
      {"body_positions", "rigid.positions", 4, DType::FLOAT32},
      {"body_rotations", "rigid.rotations", 4, DType::FLOAT32},
      {"body_linear_velocities", "rigid.linear_velocities", 4, DType::FLOAT32},
      {"body_angular_velocities", "rigid.angular_velocities", 4, DType::FLOAT32},
      {"body_contact_forces", "rigid.contact_forces", 4, DType::FLOAT32},
      {"body_contact_torques", "rigid.contact_torques", 4, DType::FLOAT32}};
  for (const auto& r : rigid) {
    if (has_rigid_) bindings_[r.hlsl] = scene.at(r.key);
    else bindings_[r.hlsl] = compute::make_typed_buffer(ctx, std::string("particles.no_") + r.hlsl, {1, r.words}, r.type, true);
  }

  // per dynamic body, how many particles pushed it in the last iteration that any did (mass
  // splitting in particle_gather: each contact takes 1/count of the body's mass)
  const int64_t nb = has_rigid_ ? scene.at("rigid.bodies")->shape[0] : 1;
  scratch("body_contact_counts", "particles.body_contact_counts", {std::max<int64_t>(nb, 1)}, DType::UINT32);

  // heat (elastic bodies with a Thermal; docs/particles.md, "Heat"), or one-element stand-ins
  {
    const int64_t nh = model_.has_heat ? n : 1;
    std::vector<float> start(size_t(nh), 0.f);
    for (int64_t i = 0; model_.has_heat && i < n; ++i) start[size_t(i)] = model_.objects[model_.phases[size_t(i)].y].heat.z;
    const std::vector<float> capacities = model_.has_heat ? model_.heat_capacities : std::vector<float>(1, 0.f);
    in("heat_capacities", "particles.heat_capacities", capacities, {nh}, DType::FLOAT32);
    in("temperatures", "particles.temperatures", start, {nh}, DType::FLOAT32, exportable && model_.has_heat);
    // what an env's reset sets them to (the Thermal's temperature; writable: a starting field)
    bindings_["reset_temperatures"] = make(control, "control.particle_reset_temperatures", start.data(),
                                           start.size() * 4, {nh}, DType::FLOAT32, false, false);
    in("damage", "particles.damage", std::vector<float>(size_t(nh), 0.f), {nh}, DType::FLOAT32,
       exportable && model_.has_heat);
    scratch("heat_rates", "particles.heat_rates", {nh}, DType::FLOAT32);
    scratch("heat_cover", "particles.heat_cover", {model_.has_heat ? ne : 1}, DType::FLOAT32);
    const std::vector<float4> off(size_t(2 * ne), float4{0, 0, 0, 0});
    bindings_["heat_sources"] = make(control, "control.heat_sources", off.data(), off.size() * sizeof(float4), {ne, 2, 4},
                                     DType::FLOAT32, false, false);
  }

  // passes
  integrate_ = pass("physics/particle_integrate", uint64_t(n));
  // the neighbour lists are built by PARTICLE_LIST_LANES threads a particle, adjacent lanes of one
  // subgroup (particle_neighbor_list.comp.hlsl)
  if (grid && ctx->subgroup_size < shader::PARTICLE_LIST_LANES)
    throw std::runtime_error("particles: the device's subgroups hold " + std::to_string(ctx->subgroup_size) +
                             " invocations; the neighbour-list build needs at least " +
                             std::to_string(shader::PARTICLE_LIST_LANES));
  if (grid) {
    grid_count_ = pass("physics/particle_grid_count", uint64_t(n));
    scan_local_ = pass("physics/particle_scan_local", table_size_);
    scan_blocks_ = pass("physics/particle_scan_blocks", 1);
    scan_add_ = pass("physics/particle_scan_add", table_size_);
    scatter_ = pass("physics/particle_grid_scatter", uint64_t(n));
    sort_ = pass("physics/particle_grid_sort", table_size_);
    neighbor_list_ = pass("physics/particle_neighbor_list", uint64_t(n) * shader::PARTICLE_LIST_LANES);
    neighbors_ = pass("physics/particle_neighbors", uint64_t(n));
  }
  if (model_.has_fluid) {
    fluid_lambda_ = pass("physics/particle_fluid_lambda", uint64_t(n));
    vorticity_ = pass("physics/particle_fluid_vorticity", uint64_t(n));
    fluid_velocity_ = pass("physics/particle_fluid_velocity", uint64_t(n));
  }
  for (uint32_t e = 0; e < uint32_t(ne); ++e)
    if (model_.env_ranges[e].range.y > largest_env_) largest_env_ = model_.env_ranges[e].range.y, largest_env_index_ = e;
  // families built on particle_solve.hlsli have one-workgroup-per-env builds too (`.blockN`)
  const auto shaders = gpu::embedded_shader_names();
  for (auto& s : model_.sets) {
    const auto c = int64_t(s.records.size());
    auto cb = in("", "particles." + s.name + "_constraints", words(s.records),
                 {c, int64_t(sizeof(shader::ParticleConstraint) / 4)}, DType::UINT32);
    auto lb = make(internal, "particles." + s.name + "_lambdas", nullptr, 0,
                   s.multipliers == 1 ? std::vector<int64_t>{c} : std::vector<int64_t>{c, int64_t(s.multipliers)},
                   DType::FLOAT32, true, false);
    // cutting: a writable flag per record, read by constraint_index() in particle_constraint.hlsli
    const std::vector<uint32_t> whole(size_t(c), 0u);
    auto cut = make(control, "control.particle_" + s.name + "_cut", whole.data(), whole.size() * 4, {c}, DType::UINT32,
                    false, false);
    if (c == 0) continue;
    auto b = bindings_;
    b["constraints"] = cb;
    b["lambdas"] = lb;
    b["cut"] = cut;
    if (s.rows_per_record) {  // vertex-solved: the records' extra rows, the coloured particles and their corners
      b["record_rows"] = in("", "particles." + s.name + "_rows", s.record_rows,
                            {c, int64_t(s.rows_per_record), 4}, DType::FLOAT32);
      b["vertices"] = in("", "particles." + s.name + "_vertices", s.vertices, {int64_t(s.vertices.size())}, DType::UINT32);
      b["vertex_records"] = in("", "particles." + s.name + "_vertex_records", s.vertex_records,
                               {int64_t(s.vertices.size()), 2}, DType::UINT32);
      b["vertex_corners"] = in("", "particles." + s.name + "_vertex_corners", s.vertex_corners,
                               {int64_t(s.vertex_corners.size())}, DType::UINT32);
    }
    if (!s.chains.empty()) {  // chain-solved: the chain table and the direct solve's per-record scratch
      b["chains"] = in("", "particles." + s.name + "_chains", s.chains, {int64_t(s.chains.size() / 2), 2}, DType::UINT32);
      b["chain_scratch"] = make(internal, "particles." + s.name + "_chain_scratch", nullptr, 0, {c, 2, 4},
                                DType::FLOAT32, true, false);
    }
    if (s.name == "tet" && model_.has_heat) {  // conduction runs over the tets' solved particles
      heat_flow_ = compute::create_builtin_pass(ctx, "physics/particle_heat_flow", b);
      heat_flow_->set_threads({uint64_t(s.vertices.size()), 1, 1});
      heat_flow_items_ = uint32_t(s.vertices.size());
      all_.push_back(heat_flow_);
      // coagulation sets the tets' material from the authored records
      auto bc = b;
      bc["initial_constraints"] = in("", "particles.tet_initial_constraints", words(s.records),
                                     {c, int64_t(sizeof(shader::ParticleConstraint) / 4)}, DType::UINT32);
      bc["initial_rows"] = in("", "particles.tet_initial_rows", s.record_rows, {c, 3, 4}, DType::FLOAT32);
      coagulate_ = compute::create_builtin_pass(ctx, "physics/particle_tet_coagulate", bc);
      coagulate_->set_threads({uint64_t(c), 1, 1});
      coagulate_reset_ = compute::create_builtin_pass(ctx, "physics/particle_tet_coagulate", bc);
      coagulate_reset_->set_threads({uint64_t(c), 1, 1});
      coagulate_items_ = uint32_t(c);
      all_.push_back(coagulate_);
      all_.push_back(coagulate_reset_);
    }
    auto p = compute::create_builtin_pass(ctx, s.shader, b);
    all_.push_back(p);
    Family f{p, nullptr, nullptr, &s};
    if (s.rows_per_record) moving_.push_back(p.get());  // the elastic solve's contacts
    if (const std::string block = block_build(*ctx, shaders, s.shader, largest_env_); !block.empty()) {
      b["env_colours"] = in("", "particles." + s.name + "_env_colours", s.env_colours,
                            {int64_t(s.env_colours.size() / 2), 2}, DType::UINT32);
      if (s.vertices.empty()) {  // particle_solve.hlsli's 16-byte records (PARTICLE_BLOCK_NONE in cressim/particle.h)
        b["block_records"] = in("", "particles." + s.name + "_block_records", block_records(s, model_.env_ranges), {c, 4},
                                DType::UINT32);
        f.pack = compute::create_builtin_pass(ctx, "physics/particle_block_pack", b);
        f.pack->set_threads({uint64_t(c), 1, 1});
        all_.push_back(f.pack);
      }
      f.per_env = compute::create_builtin_pass(ctx, block, b);
      f.per_env->groups = {uint32_t(ne), 1, 1};
      all_.push_back(f.per_env);
      if (s.rows_per_record) moving_.push_back(f.per_env.get());
    }
    families_.push_back(f);
    auto r = compute::create_builtin_pass(ctx, "physics/particle_cut_reset", b);
    r->set_threads({uint64_t(c), 1, 1});
    all_.push_back(r);
    cut_resets_.push_back({r, uint32_t(c)});
    per_substep_clears_.push_back(lb->storage->buffer.buffer);
  }
  gather_ = pass("physics/particle_gather", uint64_t(n));
  if (has_rigid_) collider_near_ = pass("physics/particle_collider_near", uint64_t(n));
  if (na > 0) attach_ = pass("physics/particle_attach", uint64_t(na));
  velocity_ = pass("physics/particle_velocity", uint64_t(n));
  if (elastic) {
    support_ = pass("physics/particle_tet_support", 1);
    support_->groups = {uint32_t(no), 1, 1};
  }
  // two-way coupling, where an env has dynamic bodies for particles to push
  if (has_rigid_ && dynamic_bodies) rigid_push_ = pass("physics/particle_rigid_push", uint64_t(ne));
  for (auto* p : {collider_near_.get(), gather_.get(), attach_.get(), fluid_lambda_.get(), rigid_push_.get()})
    if (p) moving_.push_back(p);
  // and the load of the tissue a dynamic body holds
  if (has_rigid_ && dynamic_bodies && elastic && na > 0) rigid_hold_ = pass("physics/particle_rigid_hold", uint64_t(ne));
  // one thread group an env (shader::PARTICLE_ENV_GROUP threads)
  const uint64_t env_groups = uint64_t(ne) * shader::PARTICLE_ENV_GROUP;
  if (has_rigid_) rigid_forces_ = pass("physics/particle_rigid_forces", env_groups);
  health_ = pass("physics/particle_health", env_groups);
  reset_ = pass("physics/particle_reset", uint64_t(std::max({n, na, no, ne_})));
  if (ne_ > 0) {
    orient_integrate_ = pass("physics/particle_orient_integrate", uint64_t(ne_));
    orient_velocity_ = pass("physics/particle_orient_velocity", uint64_t(ne_));
  }
  if (model_.has_heat) {
    heat_cover_ = pass("physics/particle_heat_cover", uint64_t(ne));
    heat_apply_ = pass("physics/particle_heat_apply", uint64_t(n));
  }
  if (!model_.needles.empty()) {
    needle_detect_ = pass("physics/particle_needle_detect", 1);
    needle_detect_->groups = {uint32_t(model_.needles.size()), 1, 1};  // a workgroup per needle
    needle_solve_ = pass("physics/particle_needle_solve", model_.needles.size());
    needle_reset_ = pass("physics/particle_needle_reset", model_.needles.size());
    if (has_rigid_) needle_load_ = pass("physics/particle_needle_load", model_.needles.size());
    moving_.push_back(needle_detect_.get());
    moving_.push_back(needle_solve_.get());
  }
  if (!model_.tendons.empty()) {
    tendon_ = pass("physics/particle_tendon", model_.tendon_robots.size());
    tendon_force_ = pass("physics/particle_tendon", model_.tendon_robots.size());
  }
  if (model_.has_emitters) emit_ = pass("physics/particle_emit", uint64_t(no));
  if (model_.has_fluid) remove_ = pass("physics/particle_remove", uint64_t(n));
  // a substep's iterations in one workgroup per env, where they hold nothing but the distance and
  // volume families, particle contacts, colliders and attachments (particle_iterations), or fluid
  // alone with colliders and attachments (particle_fluid_iterations)
  bool solids = !families_.empty() && !model_.has_fluid, fluid = model_.has_fluid && families_.empty();
  for (auto& f : families_) solids &= f.set->name == "distance" || f.set->name == "volume";
  for (auto& o : model_.objects) fluid &= o.range.w == shader::PARTICLE_FLUID;
  const std::string fused =
      block_build(*ctx, shaders, fluid ? "physics/particle_fluid_iterations" : "physics/particle_iterations", largest_env_);
  if (!fused.empty() && (solids || fluid) && neighbors_ && !needle_solve_ && !tendon_ && !rigid_push_) {
    auto b = bindings_;
    std::vector<uint32_t> colours(4, 0u);
    const char* slots[] = {"distance", "volume"};
    const auto unused =
        solids ? in("", "particles.iteration_unused", std::vector<uint32_t>(4, 0u), {1, 4}, DType::UINT32) : nullptr;
    for (size_t k = 0; solids && k < 2; ++k) {
      const std::string name = slots[k];
      for (const char* field : {"_records", "_lambdas", "_colours"}) b[name + field] = unused;
      for (auto& f : families_)
        if (f.set->name == name) {
          b[name + "_records"] = internal.at("particles." + name + "_block_records");
          b[name + "_lambdas"] = internal.at("particles." + name + "_lambdas");
          b[name + "_colours"] = internal.at("particles." + name + "_env_colours");
          colours[k] = uint32_t(f.set->colour_count.size());
        }
    }
    if (solids) b["family_colours"] = in("", "particles.iteration_family_colours", colours, {1, 4}, DType::UINT32);
    iterations_ = compute::create_builtin_pass(ctx, fused, b);
    iterations_->groups = {uint32_t(ne), 1, 1};
    // in group memory the fluid's lists took 0.11 ms a substep of FluidPour at 128 envs, the
    // grid's passes 0.23; the solids' kernel, a quarter the threads an env, took longer than them
    iterations_list_ = fluid;
    all_.push_back(iterations_);
    moving_.push_back(iterations_.get());
  }
  set_settings(settings);
}

std::shared_ptr<compute::ComputePass> ParticleSystem::pass(const std::string& shader, uint64_t threads) {
  auto p = compute::create_builtin_pass(ctx_, shader, bindings_);
  p->set_threads({std::max<uint64_t>(threads, 1), 1, 1});
  all_.push_back(p);
  return p;
}

void ParticleSystem::set_settings(const PhysicsSettings& s) {
  s.validate();
  if (s.max_particle_attachments_per_env != attachments_per_env_)
    throw std::invalid_argument("PhysicsSettings.max_particle_attachments_per_env sizes the attachment buffer: set it "
                                "before upload_world() (or call upload_world() again)");
  if (s.particle_solver == "workgroup" && largest_env_ > shader::PARTICLE_BLOCK_CAPACITY)
    throw std::invalid_argument("PhysicsSettings.particle_solver 'workgroup' needs every env to have at most " +
                                std::to_string(shader::PARTICLE_BLOCK_CAPACITY) + " particles; env " +
                                std::to_string(largest_env_index_) + " has " + std::to_string(largest_env_) +
                                " (use 'auto' or 'dispatch')");
  settings_ = s;
  set_constants(s);
  frame_weights(s);
}

// A rod's frames turn with a segment's inertia about a cross axis, but no lighter than the
// bending compliance over the substep squared: the XPBD bend solve then takes about half of a
// bend's correction a step instead of all of it, so the rod settles where its bending balances
// the tendons and loads at the default 4 iterations (with the physical inertia, a 0.1 m rod of
// 1 MPa bent by a tendon turned 0.92 of the way at 4 iterations and 0.99 at 256; raised, 0.996 at
// 4 from 10 kPa to 100 MPa). It slows only bending faster than the substep resolves.
void ParticleSystem::frame_weights(const PhysicsSettings& s) {
  if (model_.orientation_weights.empty()) return;
  const double h = double(s.dt) / s.particle_substep_count();
  std::vector<float> w = model_.orientation_weights;
  for (size_t e = 0; e < w.size(); ++e)
    if (model_.frame_bend_compliances[e] > 0) w[e] = float(std::min<double>(w[e], model_.frame_bend_compliances[e] / (h * h)));
  auto& b = bindings_.at("orientation_weights")->storage->buffer;
  gpu::upload(*ctx_, b, w.data(), w.size() * sizeof(float));
}

// The elastic vertex solve in one workgroup per env pays while a dispatch per colour would leave
// the GPU mostly idle; once the envs' particles fill it, those dispatches are faster (an H200,
// benchmarks/README.md: a 351-particle flap in 256 envs 4.6 against 7.4 ms a frame, in 1,024 envs
// 14.1 against 11.7 ms). `auto` takes it up to this many particles in all envs.
constexpr uint64_t kVertexBlockParticles = 131072;

bool ParticleSystem::workgroup_solve(const Family& f) const {
  if (settings_.particle_solver == "dispatch" || largest_env_ > shader::PARTICLE_BLOCK_CAPACITY) return false;
  const bool vertices = !f.set->vertices.empty();
  return !vertices || settings_.particle_solver == "workgroup" ||
         uint64_t(model_.env_ranges.size()) * largest_env_ <= kVertexBlockParticles;
}

// every constraint family `passes` times over (Gauss-Seidel between colours and families)
void ParticleSystem::record_families(VkCommandBuffer cmd, uint32_t passes) const {
  for (auto& f : families_) {
    if (f.per_env && workgroup_solve(f)) {
      const bool vertices = !f.set->vertices.empty();
      put(*f.per_env, passes, uint32_t(vertices ? f.set->vertex_colour_count.size() : f.set->colour_count.size()));
      f.per_env->record(cmd);
      gpu::compute_barrier(cmd);
      continue;
    }
    if (!f.set->vertices.empty()) {  // a thread per particle of a colour, colour after colour
      for (uint32_t pass = 0; pass < passes; ++pass)
        for (size_t k = 0; k < f.set->vertex_colour_count.size(); ++k) {
          const uint32_t count = f.set->vertex_colour_count[k];
          put(*f.per_colour, f.set->vertex_colour_offset[k], count);
          f.per_colour->groups = {(count + kGroup - 1) / kGroup, 1, 1};
          f.per_colour->record(cmd);
          gpu::compute_barrier(cmd);
        }
      continue;
    }
    if (!f.set->chains.empty()) {  // a thread per chain, all records of each at once
      const uint32_t chains = uint32_t(f.set->chains.size() / 2);
      put(*f.per_colour, 0, chains);
      f.per_colour->groups = {(chains + kGroup - 1) / kGroup, 1, 1};
      for (uint32_t pass = 0; pass < passes; ++pass) {
        f.per_colour->record(cmd);
        gpu::compute_barrier(cmd);
      }
      continue;
    }
    for (uint32_t pass = 0; pass < passes; ++pass)
      for (size_t k = 0; k < f.set->colour_count.size(); ++k) {
        put(*f.per_colour, f.set->colour_offset[k], f.set->colour_count[k]);
        f.per_colour->groups = {(f.set->colour_count[k] + kGroup - 1) / kGroup, 1, 1};
        f.per_colour->record(cmd);
        gpu::compute_barrier(cmd);
      }
  }
}

uint32_t ParticleSystem::heat_cycles(const PhysicsSettings& s) const {
  // explicit conduction is stable below m c / K_ii; half of it keeps the modes well damped
  return model_.has_heat ? std::max(1u, uint32_t(std::ceil(s.dt / (0.5 * model_.heat_step_limit)))) : 0u;
}

void ParticleSystem::set_constants(const PhysicsSettings& s) {
  for (auto& p : all_) {
    shader::ParticleConstants c{};
    c.gravity = {s.gravity[0], s.gravity[1], s.gravity[2], s.dt / float(s.particle_substep_count())};
    c.grid = {model_.cell_size, 1, s.max_speed, float(s.particle_substep_count())};
    c.cell_inverse = model_.cell_size > 0 ? float(1.0 / double(model_.cell_size)) : 0.f;
    c.particle_count = uint32_t(model_.size());
    c.table_size = table_size_;
    c.env_count = uint32_t(model_.env_ranges.size());
    c.has_rigid = has_rigid_;
    c.owns_health = !has_rigid_;
    c.attachment_count = c.env_count * attachments_per_env_;
    c.edge_count = uint32_t(model_.orientations.size());
    c.has_pins = model_.needles.empty() ? 0u : 1u;
    c.item_count = p == scan_blocks_ ? blocks_ : (p == emit_ || p == reset_) ? uint32_t(model_.objects.size()) : 0;
    for (auto& [r, records] : cut_resets_)
      if (p == r) c.item_count = records;
    for (auto& f : families_)
      if (p == f.pack) c.item_count = uint32_t(f.set->records.size());
    if (p == heat_flow_) c.item_count = heat_flow_items_;
    if (p == coagulate_ || p == coagulate_reset_) c.item_count = coagulate_items_;
    if (p == coagulate_reset_) c.item_offset = 1;  // write every tet
    if (p == heat_apply_) c.item_count = heat_cycles(s);
    if (p == tendon_ || p == tendon_force_) c.item_count = uint32_t(model_.tendon_robots.size());
    if (p == tendon_force_) c.item_offset = 1;
    if (p == needle_detect_ || p == needle_solve_ || p == needle_reset_ || p == needle_load_) c.item_count = uint32_t(model_.needles.size());
    if (p->constants.size() != sizeof(c)) throw std::logic_error("ParticleConstants does not match " + p->name);
    std::memcpy(p->constants.data(), &c, sizeof(c));
  }
}

void ParticleSystem::record_step(VkCommandBuffer cmd) const {
  auto run = [&](const std::shared_ptr<compute::ComputePass>& p) {
    if (p) {
      p->record(cmd);
      gpu::compute_barrier(cmd);
    }
  };
  const uint32_t substeps = settings_.particle_substep_count();
  run(remove_);
  run(emit_);
  bool packed = false;
  for (auto& f : families_)
    if (f.pack && workgroup_solve(f)) f.pack->record(cmd), packed = true;
  if (packed) gpu::compute_barrier(cmd);
  if (rigid_forces_) {
    vkCmdFillBuffer(cmd, frame_clear_, 0, VK_WHOLE_SIZE, 0);
    gpu::compute_barrier(cmd);
  }
  // the substep's iterations in one dispatch, which also marks the colliders near each particle
  // and takes the velocities (particle_iterations, particle_fluid_iterations, which also lists the
  // neighbours)
  const bool fused = iterations_ && settings_.particle_solver != "dispatch";
  const bool grid = grid_count_ && !(fused && iterations_list_);
  for (uint32_t s = 0; s < substeps; ++s) {
    // passes that look at moving bodies see them where they are at the end of this substep
    const float done = float(s + 1) / float(substeps);
    for (auto* p : moving_) std::memcpy(p->constants.data() + offsetof(shader::ParticleConstants, grid) + 4, &done, 4);
    for (VkBuffer b : per_substep_clears_) vkCmdFillBuffer(cmd, b, 0, VK_WHOLE_SIZE, 0);
    if (grid)
      for (VkBuffer b : grid_clears_) vkCmdFillBuffer(cmd, b, 0, VK_WHOLE_SIZE, 0);
    run(integrate_);
    if (!fused) run(collider_near_);
    run(orient_integrate_);
    run(tendon_force_);
    run(needle_detect_);
    if (grid) {
      for (auto& p : {grid_count_, scan_local_, scan_blocks_, scan_add_, scatter_, sort_, neighbor_list_}) run(p);
    }
    // the constraint families every iteration, contacts in `contacts` of them spread evenly:
    // contact iteration k follows the families' iterations up to floor((k + 1) I / C)
    const uint32_t iterations = settings_.particle_iterations;
    const uint32_t contacts = settings_.particle_contact_iterations ? settings_.particle_contact_iterations : iterations;
    if (fused) {
      put(*iterations_, iterations, contacts);
      run(iterations_);
    } else for (uint32_t k = 0; k < contacts; ++k) {
      run(fluid_lambda_);
      const uint32_t passes = (k + 1) * iterations / contacts - k * iterations / contacts;
      // punctures before the families: the elastic solve holds the tissue where they pin it, and a
      // sewn thread's own solves (stretch last) have the final say on its length
      run(needle_solve_);
      record_families(cmd, passes);
      for (uint32_t i = 0; tendon_ && i < passes; ++i) run(tendon_);
      run(neighbors_);
      run(gather_);
      run(rigid_push_);
      run(attach_);
    }
    run(support_);  // reads the substep's predicted velocities, before velocity_ replaces them
    if (!fused) run(velocity_);
    run(orient_velocity_);
    run(vorticity_);
    run(fluid_velocity_);
  }
  run(rigid_hold_);
  run(needle_load_);
  run(rigid_forces_);
  run(heat_cover_);
  for (uint32_t c = 0; heat_apply_ && c < heat_cycles(settings_); ++c) {
    run(heat_flow_);
    run(heat_apply_);
  }
  run(coagulate_);
  health_->record(cmd);
}

void ParticleSystem::record_reset(VkCommandBuffer cmd) const {
  reset_->record(cmd);
  if (needle_reset_) needle_reset_->record(cmd);
  for (auto& [p, records] : cut_resets_) p->record(cmd);
  if (coagulate_) {  // a reset env's tets as authored (its damage is 0 again): every tet written
    gpu::compute_barrier(cmd);
    coagulate_reset_->record(cmd);
  }
}

uint64_t ParticleSystem::health_events(const BufferMap& internal) const {
  const auto& b = internal.at("env.health_events")->storage->buffer;
  return b.mapped ? *static_cast<const volatile uint32_t*>(b.mapped) : 0;
}

}  // namespace cressim::physics
