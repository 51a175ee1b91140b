#include "render/particle_geometry.h"

#include <map>

namespace cressim::render {
namespace {

constexpr uint32_t kTubeSides = 8;

uint32_t add_mesh(RenderModel& m, const std::vector<uint32_t>& indices, uint32_t vertex_count) {
  m.meshes.push_back({uint32_t(m.indices.size()), uint32_t(indices.size()), int32_t(m.particle_vertex_base), 0,
                      vertex_count, {}});
  m.indices.insert(m.indices.end(), indices.begin(), indices.end());
  return uint32_t(m.meshes.size() - 1);
}

}  // namespace

ParticleMeshes add_particle_meshes(RenderModel& m, const physics::ParticleModel& p) {
  ParticleMeshes out{std::vector<int32_t>(p.objects.size(), -1), std::vector<uint32_t>(p.objects.size(), 0)};
  if (p.empty()) return out;
  m.particle_vertex_base = uint32_t(m.vertex_positions.size());
  const uint32_t n = uint32_t(p.size());
  // surfaces: generated vertex i is particle i
  m.particle_vertices.assign(n, {shader::PARTICLE_VERTEX_NONE, 0, 0, 0});
  std::vector<std::vector<uint32_t>> around(n);
  std::map<std::vector<uint32_t>, uint32_t> surface_mesh;  // by triangles relative to the first particle
  for (size_t o = 0; o < p.objects.size(); ++o) {
    const auto& obj = p.objects[o];
    if (obj.range.w != shader::PARTICLE_SOLID || p.surface_count[o] == 0) continue;
    const uint32_t first = obj.range.x;
    std::vector<uint32_t> local;
    for (uint32_t t = p.surface_offset[o]; t < p.surface_offset[o] + p.surface_count[o]; ++t) {
      const uint32_t* tri = &p.surface[3 * size_t(t)];
      for (int j = 0; j < 3; ++j) {
        local.push_back(tri[j] - first);
        around[tri[j]].push_back(uint32_t(m.particle_triangles.size()));
      }
      m.particle_triangles.push_back({tri[0], tri[1], tri[2], 0});
    }
    auto it = surface_mesh.find(local);
    if (it == surface_mesh.end()) it = surface_mesh.emplace(local, add_mesh(m, local, obj.range.y)).first;
    out.object_mesh[o] = int32_t(it->second);
    out.object_offset[o] = first;
  }
  for (uint32_t i = 0; i < n; ++i) {
    if (around[i].empty()) continue;
    m.particle_vertices[i] = {shader::PARTICLE_VERTEX_SURFACE, i, uint32_t(m.particle_adjacency.size()),
                              uint32_t(around[i].size())};
    m.particle_adjacency.insert(m.particle_adjacency.end(), around[i].begin(), around[i].end());
  }
  // strands: kTubeSides vertices around each particle, after the particles' vertices
  std::vector<uint32_t> segment_of(n, 0);  // the segment a particle starts
  for (uint32_t s = 0; s < p.edge_particles.size(); ++s) segment_of[p.edge_particles[s]] = s;
  std::map<uint32_t, uint32_t> tube_mesh;  // by particle count
  for (size_t o = 0; o < p.objects.size(); ++o) {
    const auto& obj = p.objects[o];
    const uint32_t first = obj.range.x, count = obj.range.y;
    if (obj.range.w != shader::PARTICLE_STRAND || count < 2) continue;
    out.object_offset[o] = uint32_t(m.particle_vertices.size());
    for (uint32_t i = 0; i < count; ++i) {
      // the frames of the segments on either side (one at the ends)
      const uint32_t a = segment_of[first + (i > 0 ? i - 1 : 0)], b = segment_of[first + (i + 1 < count ? i : i - 1)];
      for (uint32_t k = 0; k < kTubeSides; ++k)
        m.particle_vertices.push_back({shader::PARTICLE_VERTEX_TUBE | (k << 4) | (kTubeSides << 12), first + i, a, b});
    }
    auto it = tube_mesh.find(count);
    if (it == tube_mesh.end()) {
      std::vector<uint32_t> idx;
      for (uint32_t i = 0; i + 1 < count; ++i)
        for (uint32_t k = 0; k < kTubeSides; ++k) {
          const uint32_t a = i * kTubeSides + k, b = i * kTubeSides + (k + 1) % kTubeSides;
          idx.insert(idx.end(), {a, a + kTubeSides, b + kTubeSides, a, b + kTubeSides, b});
        }
      it = tube_mesh.emplace(count, add_mesh(m, idx, count * kTubeSides)).first;
    }
    out.object_mesh[o] = int32_t(it->second);
  }
  const size_t total = m.particle_vertex_base + m.particle_vertices.size();
  m.vertex_positions.resize(total, {0, 0, 0, 1});
  m.vertex_normals.resize(total, {0, 0, 1, 0});
  m.vertex_uvs.resize(2 * total, 0.f);
  return out;
}

}  // namespace cressim::render
