#include "render/primitives.h"

#include <cmath>
#include <numbers>

namespace cressim::render {
namespace {

void vertex(scene::Mesh& m, float x, float y, float z, float nx, float ny, float nz, float u, float v) {
  m.positions.insert(m.positions.end(), {x, y, z});
  m.normals.insert(m.normals.end(), {nx, ny, nz});
  m.uvs.insert(m.uvs.end(), {u, v});
}

// a latitude-longitude sphere (u around z, v from the top) whose two hemispheres sit `half_height` above and below z = 0;
// the band between the equator ring and the next is then the capsule's cylinder
scene::Mesh rounded(float r, float half_height, uint32_t rings, uint32_t segments) {
  scene::Mesh m;
  const float pi = std::numbers::pi_v<float>;
  rings += rings % 2;  // an equator ring to split at
  for (uint32_t i = 0; i <= rings; ++i) {
    const float theta = pi * float(i) / float(rings);  // from +z down
    const float offset = i <= rings / 2 ? half_height : -half_height;
    for (uint32_t j = 0; j <= segments; ++j) {
      const float phi = 2 * pi * float(j) / float(segments);
      const float nx = std::sin(theta) * std::cos(phi), ny = std::sin(theta) * std::sin(phi), nz = std::cos(theta);
      vertex(m, r * nx, r * ny, r * nz + offset, nx, ny, nz, float(j) / float(segments), float(i) / float(rings));
    }
  }
  for (uint32_t i = 0; i < rings; ++i)
    for (uint32_t j = 0; j < segments; ++j) {
      const uint32_t a = i * (segments + 1) + j, b = a + segments + 1;
      m.indices.insert(m.indices.end(), {a, b, a + 1, a + 1, b, b + 1});
    }
  return m;
}

}  // namespace

scene::Mesh box_mesh(std::array<float, 3> h) {
  scene::Mesh m;
  // six faces, four vertices each (flat normals)
  for (int axis = 0; axis < 3; ++axis)
    for (int sign = -1; sign <= 1; sign += 2) {
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;
      const uint32_t base = m.vertex_count();
      for (int k = 0; k < 4; ++k) {
        std::array<float, 3> p{}, n{};
        p[axis] = sign * h[axis];
        p[u] = ((k == 1 || k == 2) ? 1.f : -1.f) * h[u];
        p[v] = (k >= 2 ? 1.f : -1.f) * h[v];
        n[axis] = float(sign);
        vertex(m, p[0], p[1], p[2], n[0], n[1], n[2], (k == 1 || k == 2) ? 1.f : 0.f, k >= 2 ? 0.f : 1.f);
      }
      m.indices.insert(m.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
    }
  return m;
}

scene::Mesh sphere_mesh(float radius, uint32_t rings, uint32_t segments) { return rounded(radius, 0, rings, segments); }

scene::Mesh capsule_mesh(float radius, float half_height, uint32_t rings, uint32_t segments) {
  return rounded(radius, half_height, rings, segments);
}

scene::Mesh plane_mesh(float s) {
  scene::Mesh m;
  // one texture repeat per metre
  vertex(m, -s, -s, 0, 0, 0, 1, 0, 2 * s);
  vertex(m, s, -s, 0, 0, 0, 1, 2 * s, 2 * s);
  vertex(m, s, s, 0, 0, 0, 1, 2 * s, 0);
  vertex(m, -s, s, 0, 0, 0, 1, 0, 0);
  m.indices = {0, 1, 2, 0, 2, 3};
  return m;
}

}  // namespace cressim::render
