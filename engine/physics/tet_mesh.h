// Tetrahedral meshes for soft bodies: a built-in box and cylinder tetrahedraliser, a Gmsh .msh
// reader (ASCII v2 and v4), and the boundary surface (faces of one tet only, outward).
#pragma once
#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace cressim::physics {

struct TetMesh {
  std::vector<float> positions;      // x y z per vertex
  std::vector<uint32_t> tets;        // 4 per tetrahedron, positive volume
  std::vector<uint32_t> triangles;   // 3 per boundary face, counter-clockwise seen from outside
  uint32_t vertex_count() const { return uint32_t(positions.size() / 3); }
  uint32_t tet_count() const { return uint32_t(tets.size() / 4); }
};

// a box centred at the origin, `cells` cubes an axis, each cube split into 6 tets along its main
// diagonal (the same diagonal everywhere, so neighbouring cubes share faces exactly)
TetMesh tetrahedralize_box(std::array<float, 3> half_extents, std::array<uint32_t, 3> cells);
// a cylinder along z centred at the origin: the box grid's tets whose centroid lies inside
TetMesh tetrahedralize_cylinder(float radius, float half_height, uint32_t cells_across, uint32_t cells_along);
// Gmsh .msh, ASCII format 2.2 or 4.1: nodes and 4-node tetrahedra (other elements ignored)
TetMesh load_msh(const std::string& path);

// orients every tet positively and rebuilds the boundary triangles
void finish_tet_mesh(TetMesh& mesh);

}  // namespace cressim::physics
