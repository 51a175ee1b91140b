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
  // surfaces: a vertex per particle on an object's surface, in particle order (interior and
  // fluid particles get none)
  std::vector<std::vector<uint32_t>> around;  // per generated vertex: its triangles
  std::map<std::vector<uint32_t>, uint32_t> surface_mesh;  // by triangles in the object's vertex numbering
  for (size_t o = 0; o < p.objects.size(); ++o) {
    const auto& obj = p.objects[o];
    if (obj.range.w != shader::PARTICLE_SOLID || p.surface_count[o] == 0) continue;
    const uint32_t* tris = &p.surface[3 * size_t(p.surface_offset[o])];
    const size_t corners = 3 * size_t(p.surface_count[o]);
    std::map<uint32_t, uint32_t> slot;  // particle -> its vertex within the object's
    for (size_t c = 0; c < corners; ++c) slot.emplace(tris[c], 0);
    const uint32_t first = uint32_t(m.particle_vertices.size());
    for (auto& [particle, s] : slot) {
      s = uint32_t(m.particle_vertices.size()) - first;
      m.particle_vertices.push_back({shader::PARTICLE_VERTEX_SURFACE, particle, 0, 0});
      around.emplace_back();
    }
    std::vector<uint32_t> local;
    for (size_t c = 0; c < corners; c += 3) {
      for (size_t j = 0; j < 3; ++j) {
        local.push_back(slot[tris[c + j]]);
        around[first + local.back()].push_back(uint32_t(m.particle_triangles.size()));
      }
      m.particle_triangles.push_back({tris[c], tris[c + 1], tris[c + 2], 0});
    }
    auto it = surface_mesh.find(local);
    if (it == surface_mesh.end()) it = surface_mesh.emplace(local, add_mesh(m, local, uint32_t(slot.size()))).first;
    out.object_mesh[o] = int32_t(it->second);
    out.object_offset[o] = first;
  }
  for (size_t v = 0; v < around.size(); ++v) {
    m.particle_vertices[v].z = uint32_t(m.particle_adjacency.size());
    m.particle_vertices[v].w = uint32_t(around[v].size());
    m.particle_adjacency.insert(m.particle_adjacency.end(), around[v].begin(), around[v].end());
  }
  // strands: kTubeSides vertices around each particle, and two cap centres
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
    // the end caps' centres: the end particles, normals along the end segments (out)
    const uint32_t last = first + count - 1;
    m.particle_vertices.push_back({shader::PARTICLE_VERTEX_CAP, first, segment_of[first], 0});
    m.particle_vertices.push_back({shader::PARTICLE_VERTEX_CAP, last, segment_of[last - 1], 1});
    auto it = tube_mesh.find(count);
    if (it == tube_mesh.end()) {
      std::vector<uint32_t> idx;
      const uint32_t start_cap = count * kTubeSides, end_cap = start_cap + 1, end_ring = (count - 1) * kTubeSides;
      for (uint32_t k = 0; k < kTubeSides; ++k) {
        const uint32_t next = (k + 1) % kTubeSides;
        for (uint32_t i = 0; i + 1 < count; ++i) {
          const uint32_t a = i * kTubeSides + k, b = i * kTubeSides + next;
          idx.insert(idx.end(), {a, a + kTubeSides, b + kTubeSides, a, b + kTubeSides, b});
        }
        idx.insert(idx.end(), {start_cap, next, k, end_cap, end_ring + k, end_ring + next});
      }
      it = tube_mesh.emplace(count, add_mesh(m, idx, count * kTubeSides + 2)).first;
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
