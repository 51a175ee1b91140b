"""Tet meshes from files (cressim/tet_mesh_file.py): a box written to legacy VTK (both CELLS
layouts) reads back as TetMesh.box (same points, tets, boundary and volume); other cells are
ignored, unused points dropped and inverted tets turned; malformed files name their line."""
import numpy as np
import pytest

import cressim
from cressim.tet_mesh_file import MeshFileError, load_tet_mesh, read_vtk
from vtk_files import vtk_lines

HALF, CELLS = (0.03, 0.02, 0.003), (3, 2, 2)


def write(tmp_path, lines, name="mesh.vtk"):
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n")
    return path


def volume(points, tets):
    a, b, c, d = (points[tets[:, k]].astype(np.float64) for k in range(4))
    return np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a)) / 6


def geometry(points, cells):
    """Cells as sets of their corners' coordinates (rounded), whatever the point numbering; a
    triangle keeps its winding (turned to start at its smallest corner)."""
    corners = [tuple(map(tuple, np.round(points[c].astype(np.float64), 9).tolist())) for c in np.asarray(cells)]
    if len(cells[0]) == 4:
        return {tuple(sorted(c)) for c in corners}
    return {c[c.index(min(c)):] + c[:c.index(min(c))] for c in corners}


def cyclic(triangles):
    """Triangles as a set, each turned to start at its smallest index (winding kept)."""
    return {tuple(np.roll(t, -int(np.argmin(t)))) for t in np.asarray(triangles)}


@pytest.mark.parametrize("layout", ["classic", "5.1"])
def test_a_box_read_from_vtk_is_the_box(tmp_path, layout):
    box = cressim.TetMesh.box(HALF, CELLS)
    path = write(tmp_path, vtk_lines(box.positions, box.tets, [10] * len(box.tets), layout))
    mesh = read_vtk(path)
    assert np.array_equal(mesh.positions, box.positions) and np.array_equal(mesh.tets, box.tets)
    assert volume(mesh.positions, mesh.tets).sum() == pytest.approx(8 * np.prod(HALF), rel=1e-6)
    assert volume(mesh.positions, mesh.tets).sum() == pytest.approx(volume(box.positions, box.tets).sum(), rel=1e-9)
    assert cyclic(mesh.triangles) == cyclic(box.triangles)  # the same boundary, wound the same way (outward)


def test_other_cells_are_ignored_unused_points_dropped_and_tets_turned(tmp_path):
    box = cressim.TetMesh.box(HALF, (1, 1, 1))
    stray = np.array([[1.0, 1.0, 1.0]])  # point 0 here: only a vertex cell uses it
    points = np.vstack([stray, box.positions])
    tets = [list(t[[0, 1, 3, 2]] + 1) for t in box.tets]  # every tet inverted
    cells = [[0], [1, 2, 3], *tets, [1, 2]]  # a vertex, a triangle, the tets, a line
    path = write(tmp_path, vtk_lines(points, cells, [1, 5] + [10] * len(tets) + [3]))
    mesh = read_vtk(path)
    assert np.array_equal(mesh.positions, box.positions)
    assert (volume(mesh.positions, mesh.tets) > 0).all()
    assert cyclic(mesh.triangles) == cyclic(box.triangles)


def test_metadata_and_field_blocks_are_skipped_and_point_data_ends_the_read(tmp_path):
    box = cressim.TetMesh.box(HALF, (1, 1, 1))
    lines = vtk_lines(box.positions, box.tets, [10] * len(box.tets))
    at = lines.index(next(x for x in lines if x.startswith("CELLS")))
    lines[at:at] = ["METADATA", "INFORMATION 1", "NAME L2_NORM_RANGE LOCATION vtkDataArray", "DATA 2 0 1", ""]
    lines[4:4] = ["FIELD FieldData 1", "TIME 1 1 double", "0.5"]
    lines += ["POINT_DATA 8", "SCALARS t float 1", "LOOKUP_TABLE default"] + ["0"] * 8
    mesh = read_vtk(write(tmp_path, lines))
    assert np.array_equal(mesh.tets, box.tets)


def test_load_tet_mesh_scales_vtk_and_msh_alike(tmp_path):
    box = cressim.TetMesh.box(HALF, (1, 1, 1))
    vtk = write(tmp_path, vtk_lines(box.positions, box.tets, [10] * len(box.tets)))
    msh = ["$MeshFormat", "2.2 0 8", "$EndMeshFormat", "$Nodes", str(len(box.positions))]
    msh += [f"{i + 1} " + " ".join(repr(float(c)) for c in p) for i, p in enumerate(box.positions)]
    msh += ["$EndNodes", "$Elements", str(len(box.tets))]
    msh += [f"{i + 1} 4 0 {' '.join(str(v + 1) for v in t)}" for i, t in enumerate(box.tets)] + ["$EndElements"]
    msh = write(tmp_path, msh, "mesh.msh")
    for path in (vtk, msh):  # Gmsh's reader numbers the points in the order the tets use them
        mesh = load_tet_mesh(path, scale=2.0)
        assert geometry(mesh.positions, mesh.tets) == geometry(2 * box.positions, box.tets)
        assert geometry(mesh.positions, mesh.triangles) == geometry(2 * box.positions, box.triangles)
    with pytest.raises(MeshFileError, match=r"mesh\.obj: a tet mesh is a Gmsh \.msh or a legacy VTK \.vtk file"):
        load_tet_mesh(tmp_path / "mesh.obj")
    with pytest.raises(ValueError, match="scale must be positive, got nan"):
        load_tet_mesh(vtk, scale=float("nan"))


def one_tet(**change):
    """Line numbers: 5 POINTS, 6-9 the points, 10 CELLS, 11 the tet, 12 CELL_TYPES, 13 its type."""
    lines = vtk_lines([(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)], [[0, 1, 2, 3]], [10])
    for line, text in change.items():
        lines[int(line[1:]) - 1] = text
    return lines


@pytest.mark.parametrize("change, line, message", [
    ({"l1": "solid box"}, 1, "not a legacy VTK file"),
    ({"l3": "BINARY"}, 3, "expected ASCII, got 'BINARY'; save it as ASCII"),
    ({"l4": "DATASET POLYDATA"}, 4, "the dataset is POLYDATA; a tet mesh is an UNSTRUCTURED_GRID"),
    ({"l7": "1 zero 0"}, 7, "POINTS: expected a number, got 'zero'"),
    ({"l8": "0 nan 0"}, 8, "POINTS: coordinates must be finite, got nan"),
    ({"l5": "POINTS 5 double"}, 10, "POINTS: expected a number, got 'CELLS'"),
    ({"l11": "4 0 1 2 7"}, 11, "the cell names point 7; there are 4 points"),
    ({"l10": "CELLS 1 4", "l11": "3 0 1 2"}, 11, "a tetrahedron (type 10) has 4 points, this cell has 3"),
    ({"l10": "CELLS 1 6"}, 11, "CELLS says 6 numbers, its cells hold 5"),
    ({"l12": "CELL_TYPES 2"}, 12, "CELL_TYPES gives 2 types for 1 cells"),
    ({"l13": "5"}, 13, "no tetrahedra (cell type 10)"),
    ({"l9": "1 1 0"}, 11, "the tetrahedron has no volume"),
    ({"l12": "CELL_DATA 1"}, 13, "no CELL_TYPES section"),
    ({"l12": "CELL_TYPE 1"}, 12, "unknown section 'CELL_TYPE'"),
])
def test_malformed_files_name_the_line(tmp_path, change, line, message):
    path = write(tmp_path, one_tet(**change))
    with pytest.raises(MeshFileError) as e:
        read_vtk(path)
    assert str(e.value).startswith(f"{path}:{line}: {message}"), str(e.value)


def test_a_truncated_file_names_its_last_line(tmp_path):
    path = write(tmp_path, one_tet()[:8])  # three of the four points
    with pytest.raises(MeshFileError, match=r"mesh\.vtk:8: POINTS ends early: expected 12 numbers, the file has 9"):
        read_vtk(path)
