#include "physics/tet_mesh.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

namespace cressim::physics {
namespace {

using V3 = std::array<float, 3>;

V3 vertex(const TetMesh& m, uint32_t i) { return {m.positions[3 * i], m.positions[3 * i + 1], m.positions[3 * i + 2]}; }
V3 sub(V3 a, V3 b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
V3 cross(V3 a, V3 b) { return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]}; }
float dot(V3 a, V3 b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

// the unit-cube grid of (cells+1)^3 vertices, 6 tets per cube (Kuhn subdivision)
TetMesh grid(V3 lo, V3 step, std::array<uint32_t, 3> n) {
  TetMesh m;
  const uint32_t nx = n[0] + 1, ny = n[1] + 1, nz = n[2] + 1;
  for (uint32_t k = 0; k < nz; ++k)
    for (uint32_t j = 0; j < ny; ++j)
      for (uint32_t i = 0; i < nx; ++i)
        m.positions.insert(m.positions.end(), {lo[0] + i * step[0], lo[1] + j * step[1], lo[2] + k * step[2]});
  auto id = [&](uint32_t i, uint32_t j, uint32_t k) { return i + nx * (j + ny * k); };
  static const int perms[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (uint32_t k = 0; k < n[2]; ++k)
    for (uint32_t j = 0; j < n[1]; ++j)
      for (uint32_t i = 0; i < n[0]; ++i)
        for (auto& p : perms) {
          uint32_t c[3] = {i, j, k};
          uint32_t t[4];
          t[0] = id(c[0], c[1], c[2]);
          for (int s = 0; s < 3; ++s) {
            ++c[p[s]];
            t[s + 1] = id(c[0], c[1], c[2]);
          }
          m.tets.insert(m.tets.end(), t, t + 4);
        }
  return m;
}

// drops vertices no tet uses, renumbering the tets
void compact(TetMesh& m) {
  std::vector<int64_t> remap(m.vertex_count(), -1);
  std::vector<float> pos;
  for (uint32_t& v : m.tets) {
    if (remap[v] < 0) {
      remap[v] = int64_t(pos.size() / 3);
      const V3 p = vertex(m, v);
      pos.insert(pos.end(), p.begin(), p.end());
    }
    v = uint32_t(remap[v]);
  }
  m.positions = std::move(pos);
}

[[noreturn]] void bad(const std::string& path, const std::string& why) {
  throw std::invalid_argument("load_msh('" + path + "'): " + why);
}

}  // namespace

void finish_tet_mesh(TetMesh& m) {
  if (m.tets.size() % 4 || m.positions.size() % 3) throw std::invalid_argument("tet mesh: 4 indices per tet, 3 numbers per vertex");
  for (uint32_t v : m.tets)
    if (v >= m.vertex_count())
      throw std::invalid_argument("tet mesh: index " + std::to_string(v) + " beyond the " +
                                  std::to_string(m.vertex_count()) + " vertices");
  // faces seen once are the boundary; the opposite vertex says which side is inside
  std::map<std::array<uint32_t, 3>, std::pair<int, std::array<uint32_t, 4>>> faces;
  for (uint32_t t = 0; t < m.tet_count(); ++t) {
    uint32_t* q = &m.tets[4 * t];
    const V3 a = vertex(m, q[0]);
    const float six_v = dot(sub(vertex(m, q[1]), a), cross(sub(vertex(m, q[2]), a), sub(vertex(m, q[3]), a)));
    if (std::abs(six_v) < 1e-18f) throw std::invalid_argument("tet mesh: tet " + std::to_string(t) + " has no volume");
    if (six_v < 0) std::swap(q[2], q[3]);
    static const int f[4][4] = {{0, 1, 2, 3}, {0, 1, 3, 2}, {0, 2, 3, 1}, {1, 2, 3, 0}};
    for (auto& fi : f) {
      std::array<uint32_t, 3> key{q[fi[0]], q[fi[1]], q[fi[2]]};
      std::sort(key.begin(), key.end());
      auto& e = faces[key];
      ++e.first;
      e.second = {q[fi[0]], q[fi[1]], q[fi[2]], q[fi[3]]};
    }
  }
  m.triangles.clear();
  for (auto& [key, e] : faces) {
    if (e.first != 1) continue;
    auto [a, b, c, d] = e.second;
    const V3 pa = vertex(m, a);
    if (dot(cross(sub(vertex(m, b), pa), sub(vertex(m, c), pa)), sub(vertex(m, d), pa)) > 0) std::swap(b, c);
    m.triangles.insert(m.triangles.end(), {a, b, c});
  }
}

TetMesh tetrahedralize_box(std::array<float, 3> h, std::array<uint32_t, 3> cells) {
  for (int i = 0; i < 3; ++i) {
    if (!(h[i] > 0)) throw std::invalid_argument("tetrahedralize_box: half_extents must be positive");
    if (cells[i] < 1) throw std::invalid_argument("tetrahedralize_box: at least one cell an axis");
  }
  TetMesh m = grid({-h[0], -h[1], -h[2]}, {2 * h[0] / cells[0], 2 * h[1] / cells[1], 2 * h[2] / cells[2]}, cells);
  finish_tet_mesh(m);
  return m;
}

TetMesh tetrahedralize_cylinder(float radius, float half_height, uint32_t across, uint32_t along) {
  if (!(radius > 0) || !(half_height > 0)) throw std::invalid_argument("tetrahedralize_cylinder: sizes must be positive");
  if (across < 2 || along < 1) throw std::invalid_argument("tetrahedralize_cylinder: at least 2 cells across, 1 along");
  TetMesh g = grid({-radius, -radius, -half_height}, {2 * radius / across, 2 * radius / across, 2 * half_height / along},
                   {across, across, along});
  TetMesh m;
  m.positions = g.positions;
  for (uint32_t t = 0; t < g.tet_count(); ++t) {
    float cx = 0, cy = 0;
    for (int k = 0; k < 4; ++k) cx += 0.25f * g.positions[3 * g.tets[4 * t + k]], cy += 0.25f * g.positions[3 * g.tets[4 * t + k] + 1];
    if (cx * cx + cy * cy <= radius * radius) m.tets.insert(m.tets.end(), &g.tets[4 * t], &g.tets[4 * t] + 4);
  }
  if (m.tets.empty()) throw std::invalid_argument("tetrahedralize_cylinder: no tets inside; use more cells");
  compact(m);
  finish_tet_mesh(m);
  return m;
}

TetMesh load_msh(const std::string& path) {
  std::ifstream in(path);
  if (!in) bad(path, "cannot open the file");
  std::string line;
  double version = 0;
  std::unordered_map<uint64_t, uint32_t> node_index;
  TetMesh m;
  std::vector<uint64_t> tet_tags;
  while (std::getline(in, line)) {
    if (line.rfind("$MeshFormat", 0) == 0) {
      int file_type = 0;
      in >> version >> file_type;
      if (file_type != 0) bad(path, "binary .msh is not supported; save as ASCII");
      if (!(version >= 2 && version < 3) && !(version >= 4 && version < 5))
        bad(path, "format version " + std::to_string(version) + " is not 2.x or 4.x");
    } else if (line.rfind("$Nodes", 0) == 0) {
      if (version == 0) bad(path, "no $MeshFormat before $Nodes");
      auto add_node = [&](uint64_t tag, double x, double y, double z) {
        node_index[tag] = m.vertex_count();
        m.positions.insert(m.positions.end(), {float(x), float(y), float(z)});
      };
      if (version < 3) {
        size_t n = 0;
        in >> n;
        for (size_t i = 0; i < n; ++i) {
          uint64_t tag;
          double x, y, z;
          if (!(in >> tag >> x >> y >> z)) bad(path, "truncated $Nodes");
          add_node(tag, x, y, z);
        }
      } else {
        size_t blocks = 0, total = 0, lo, hi;
        in >> blocks >> total >> lo >> hi;
        for (size_t b = 0; b < blocks; ++b) {
          int dim, entity, parametric;
          size_t n;
          if (!(in >> dim >> entity >> parametric >> n)) bad(path, "truncated $Nodes block");
          if (parametric) bad(path, "parametric nodes are not supported");
          std::vector<uint64_t> tags(n);
          for (auto& t : tags) in >> t;
          for (size_t i = 0; i < n; ++i) {
            double x, y, z;
            if (!(in >> x >> y >> z)) bad(path, "truncated node coordinates");
            add_node(tags[i], x, y, z);
          }
        }
      }
    } else if (line.rfind("$Elements", 0) == 0) {
      auto add_tet = [&](const uint64_t* t) {
        for (int k = 0; k < 4; ++k) {
          auto it = node_index.find(t[k]);
          if (it == node_index.end()) bad(path, "a tetrahedron names node " + std::to_string(t[k]) + ", which $Nodes lacks");
          m.tets.push_back(it->second);
        }
      };
      if (version < 3) {
        size_t n = 0;
        in >> n;
        std::getline(in, line);
        for (size_t i = 0; i < n; ++i) {
          if (!std::getline(in, line)) bad(path, "truncated $Elements");
          std::istringstream ls(line);
          uint64_t tag, type, ntags, x;
          ls >> tag >> type >> ntags;
          for (uint64_t k = 0; k < ntags; ++k) ls >> x;
          if (type != 4) continue;  // 4: 4-node tetrahedron
          uint64_t t[4];
          if (!(ls >> t[0] >> t[1] >> t[2] >> t[3])) bad(path, "element " + std::to_string(tag) + " is truncated");
          add_tet(t);
        }
      } else {
        size_t blocks = 0, total, lo, hi;
        in >> blocks >> total >> lo >> hi;
        for (size_t b = 0; b < blocks; ++b) {
          int dim, entity, type;
          size_t n;
          if (!(in >> dim >> entity >> type >> n)) bad(path, "truncated $Elements block");
          std::getline(in, line);
          for (size_t i = 0; i < n; ++i) {
            if (!std::getline(in, line)) bad(path, "truncated $Elements");
            if (type != 4) continue;
            std::istringstream ls(line);
            uint64_t tag, t[4];
            if (!(ls >> tag >> t[0] >> t[1] >> t[2] >> t[3])) bad(path, "element " + std::to_string(tag) + " is truncated");
            add_tet(t);
          }
        }
      }
    }
  }
  if (m.positions.empty()) bad(path, "no $Nodes section");
  if (m.tets.empty()) bad(path, "no 4-node tetrahedra (element type 4)");
  compact(m);
  finish_tet_mesh(m);
  return m;
}

}  // namespace cressim::physics
