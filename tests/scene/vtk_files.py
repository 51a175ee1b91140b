"""Legacy VTK files for the tests: a mesh's points and cells as the lines of an ASCII
unstructured grid, in the classic CELLS layout or the 5.x one (OFFSETS and CONNECTIVITY)."""
import numpy as np


def vtk_lines(points, cells, types, layout="classic"):
    """A legacy ASCII VTK unstructured grid: cells are lists of point indices."""
    out = ["# vtk DataFile Version 3.0" if layout == "classic" else "# vtk DataFile Version 5.1", "test mesh", "ASCII",
           "DATASET UNSTRUCTURED_GRID", f"POINTS {len(points)} double"]
    out += [" ".join(repr(float(c)) for c in p) for p in points]
    if layout == "classic":
        out += [f"CELLS {len(cells)} {sum(len(c) + 1 for c in cells)}"]
        out += [" ".join(map(str, [len(c), *c])) for c in cells]
    else:
        offsets = np.cumsum([0] + [len(c) for c in cells])
        out += [f"CELLS {len(cells) + 1} {offsets[-1]}", "OFFSETS vtktypeint64", " ".join(map(str, offsets)),
                "CONNECTIVITY vtktypeint64"] + [" ".join(map(str, c)) for c in cells]
    out += [f"CELL_TYPES {len(types)}"] + [str(t) for t in types]
    return out
