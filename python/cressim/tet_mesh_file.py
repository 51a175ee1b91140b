"""Tetrahedral meshes read from files, for soft bodies: Gmsh `.msh` (through cressim.TetMesh.load)
and legacy VTK unstructured grids (`.vtk`, ASCII), read here.

VTK: the classic layout (`CELLS n size` followed by `k i0 .. ik-1` per cell) and the 5.x one
(`CELLS`, then `OFFSETS` and `CONNECTIVITY` arrays) are both read; cells of type 10 (4-node
tetrahedra) are kept and other cells ignored; `METADATA` and `FIELD` blocks are skipped, and
reading stops at `POINT_DATA` / `CELL_DATA` (nothing after the cells is needed). A malformed
file raises MeshFileError naming the file and the line.

Every mesh comes back the same way: points no tet uses dropped (the others keep their order,
since a tet-less particle has no mass), tets positively oriented, and the boundary (faces used
by one tet) as triangles wound outward, which is what cressim.SoftBody takes.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

import cressim

VTK_TETRA = 10
# the faces of a positive tet (a, b, c, d), each wound so its normal points away from the fourth corner
_OUTWARD_FACES = ((0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3))


class MeshFileError(ValueError):
    """A mesh file that cannot be read; the message starts with file:line."""


@dataclass(frozen=True)
class TetMeshArrays:
    positions: np.ndarray  # (n, 3) float32
    tets: np.ndarray       # (m, 4) int64, positive volume
    triangles: np.ndarray  # (k, 3) int64, the boundary, wound outward


def load_tet_mesh(path, scale: float = 1.0) -> TetMeshArrays:
    """The tet mesh in a .msh or .vtk file, its coordinates multiplied by `scale`."""
    path = Path(path)
    if not (np.isfinite(scale) and scale > 0):
        raise ValueError(f"load_tet_mesh: scale must be positive, got {scale}")
    suffix = path.suffix.lower()
    if suffix == ".msh":
        mesh = cressim.TetMesh.load(str(path))
        out = TetMeshArrays(mesh.positions, mesh.tets.astype(np.int64), mesh.triangles.astype(np.int64))
    elif suffix == ".vtk":
        out = read_vtk(path)
    else:
        raise MeshFileError(f"{path}: a tet mesh is a Gmsh .msh or a legacy VTK .vtk file, not '{path.suffix}'")
    return TetMeshArrays((out.positions.astype(np.float64) * scale).astype(np.float32), out.tets, out.triangles)


def read_vtk(path) -> TetMeshArrays:
    """The tetrahedra of a legacy ASCII VTK unstructured grid."""
    path = Path(path)
    lines = path.read_text().splitlines()
    if not lines or not lines[0].lower().lstrip("# ").startswith("vtk datafile version"):
        raise MeshFileError(f"{path}:1: not a legacy VTK file (the first line is '# vtk DataFile Version x.y')")
    if len(lines) < 3 or lines[2].strip().upper() != "ASCII":
        what = lines[2].strip() if len(lines) >= 3 else "nothing"
        hint = "; save it as ASCII" if what.upper() == "BINARY" else ""
        raise MeshFileError(f"{path}:3: expected ASCII, got '{what}'{hint}")
    tokens = _Tokens(path, lines)
    keyword, line = tokens.next("DATASET")
    if keyword.upper() != "DATASET":
        raise tokens.fail(f"expected DATASET, got '{keyword}'", line)
    kind, line = tokens.next("the dataset's type")
    if kind.upper() != "UNSTRUCTURED_GRID":
        raise tokens.fail(f"the dataset is {kind}; a tet mesh is an UNSTRUCTURED_GRID", line)
    points = cells = types = None
    while not tokens.done():
        section, line = tokens.next("a section")
        name = section.upper()
        if name in ("POINT_DATA", "CELL_DATA"):
            break
        if name == "POINTS":
            n = tokens.int("the point count", 1)
            tokens.next("the points' type")
            points = tokens.floats(3 * n, "POINTS").reshape(n, 3)
        elif name == "CELLS":
            cells = _cells(tokens)
        elif name == "CELL_TYPES":
            m = tokens.int("the cell type count", 0)
            if cells is not None and m != len(cells):
                raise tokens.fail(f"CELL_TYPES gives {m} types for {len(cells)} cells", line)
            types = [tokens.int("a cell type", 0) for _ in range(m)]
        elif name == "METADATA":
            tokens.skip_block()
        elif name == "FIELD":
            tokens.skip_field()
        else:
            raise tokens.fail(f"unknown section '{section}'", line)
    for what, got in (("POINTS", points), ("CELLS", cells), ("CELL_TYPES", types)):
        if got is None:
            raise tokens.fail(f"no {what} section", len(lines))
    if len(types) != len(cells):
        raise tokens.fail(f"CELL_TYPES gives {len(types)} types for {len(cells)} cells", len(lines))
    tets = []
    for (ids, line), kind in zip(cells, types):
        if kind != VTK_TETRA:
            continue
        if len(ids) != 4:
            raise tokens.fail(f"a tetrahedron (type 10) has 4 points, this cell has {len(ids)}", line)
        for i in ids:
            if i >= len(points):
                raise tokens.fail(f"the cell names point {i}; there are {len(points)} points", line)
        tets.append((ids, line))
    if not tets:
        raise tokens.fail("no tetrahedra (cell type 10)", len(lines))
    tet_ids = np.array([ids for ids, _ in tets], np.int64)
    volumes = _six_volumes(points, tet_ids)
    edge = np.linalg.norm(points[tet_ids[:, 1:]] - points[tet_ids[:, :1]], axis=2).max(axis=1)
    flat = np.abs(volumes) <= 1e-9 * edge ** 3
    if flat.any():
        raise tokens.fail("the tetrahedron has no volume", tets[int(np.argmax(flat))][1])
    return _finish(points, tet_ids)


def boundary_triangles(positions: np.ndarray, tets: np.ndarray) -> np.ndarray:
    """The faces used by exactly one of the (positive) tets, wound outward."""
    faces = tets[:, _OUTWARD_FACES].reshape(-1, 3)
    _, first, count = np.unique(np.sort(faces, axis=1), axis=0, return_index=True, return_counts=True)
    return faces[np.sort(first[count == 1])]


def _six_volumes(points: np.ndarray, tets: np.ndarray) -> np.ndarray:
    a, b, c, d = (points[tets[:, k]] for k in range(4))
    return np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a))


def _finish(points: np.ndarray, tets: np.ndarray) -> TetMeshArrays:
    used = np.zeros(len(points), bool)
    used[tets.ravel()] = True
    new_index = np.cumsum(used) - 1
    points, tets = points[used], new_index[tets]
    negative = _six_volumes(points, tets) < 0
    tets[negative] = tets[negative][:, (0, 1, 3, 2)]
    return TetMeshArrays(points.astype(np.float32), tets, boundary_triangles(points, tets))


def _cells(tokens: "_Tokens") -> list[tuple[list[int], int]]:
    """(point ids, line) per cell, from either CELLS layout."""
    a = tokens.int("the cell count", 0)
    b = tokens.int("the cell list size", 0)
    if tokens.peek().upper() == "OFFSETS":  # 5.x: a offsets (cells + 1), b connectivity entries
        tokens.next("OFFSETS")
        tokens.next("the offsets' type")
        offsets = [tokens.int("an offset", 0) for _ in range(a)]
        keyword, line = tokens.next("CONNECTIVITY")
        if keyword.upper() != "CONNECTIVITY":
            raise tokens.fail(f"expected CONNECTIVITY, got '{keyword}'", line)
        tokens.next("the connectivity's type")
        ids, lines = [], []
        for _ in range(b):
            ids.append(tokens.int("a point index", 0))
            lines.append(tokens.line)
        if a == 0 or offsets[0] != 0 or offsets[-1] != b or any(x > y for x, y in zip(offsets, offsets[1:])):
            raise tokens.fail(f"OFFSETS must rise from 0 to the {b} CONNECTIVITY entries", line)
        return [(ids[s:e], lines[s] if s < e else line) for s, e in zip(offsets, offsets[1:])]
    cells, used = [], 0
    for _ in range(a):
        k = tokens.int("a cell's point count", 0)
        line = tokens.line
        cells.append(([tokens.int("a point index", 0) for _ in range(k)], line))
        used += k + 1
    if used != b:
        raise tokens.fail(f"CELLS says {b} numbers, its cells hold {used}", tokens.line)
    return cells


class _Tokens:
    """The whitespace-separated words after the header, each with its line number."""

    def __init__(self, path: Path, lines: list[str]):
        self.path, self.lines = path, lines
        self.items = [(word, no) for no, text in enumerate(lines[3:], 4) for word in text.split()]
        self.pos, self.line = 0, 3

    def fail(self, message: str, line: int) -> MeshFileError:
        return MeshFileError(f"{self.path}:{line}: {message}")

    def done(self) -> bool:
        return self.pos >= len(self.items)

    def peek(self) -> str:
        return "" if self.done() else self.items[self.pos][0]

    def next(self, what: str) -> tuple[str, int]:
        if self.done():
            raise self.fail(f"the file ends before {what}", len(self.lines))
        word, self.line = self.items[self.pos]
        self.pos += 1
        return word, self.line

    def int(self, what: str, minimum: int) -> int:
        word, line = self.next(what)
        try:
            v = int(word)
        except ValueError:
            raise self.fail(f"expected {what} (an integer), got '{word}'", line) from None
        if v < minimum:
            raise self.fail(f"{what} must be >= {minimum}, got {v}", line)
        return v

    def floats(self, count: int, what: str) -> np.ndarray:
        if self.pos + count > len(self.items):
            raise self.fail(f"{what} ends early: expected {count} numbers, the file has "
                            f"{len(self.items) - self.pos}", len(self.lines))
        chunk = self.items[self.pos:self.pos + count]
        out = np.empty(count)
        for i, (word, line) in enumerate(chunk):
            try:
                out[i] = float(word)
            except ValueError:
                raise self.fail(f"{what}: expected a number, got '{word}'", line) from None
            if not np.isfinite(out[i]):
                raise self.fail(f"{what}: coordinates must be finite, got {word}", line)
        self.pos += count
        self.line = chunk[-1][1] if chunk else self.line
        return out

    def skip_block(self) -> None:
        """A METADATA block: it ends at the next blank line."""
        blank = next((no for no in range(self.line + 1, len(self.lines) + 1) if not self.lines[no - 1].strip()),
                     len(self.lines) + 1)
        while not self.done() and self.items[self.pos][1] < blank:
            self.pos += 1

    def skip_field(self) -> None:
        """FIELD name count, then per array: name components tuples type and its values."""
        self.next("the FIELD's name")
        for _ in range(self.int("the FIELD's array count", 0)):
            self.next("an array's name")
            n = self.int("the array's component count", 0) * self.int("the array's tuple count", 0)
            self.next("the array's type")
            for _ in range(n):
                self.next("the array's values")
