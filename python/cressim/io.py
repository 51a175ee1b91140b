"""Files in and out of the renderer: PNG images (a small zlib writer, no imaging library),
depth and segmentation colour maps for people to look at, and meshes and textures read from
.obj/.stl/.glb/.png files (trimesh and matplotlib, imported when used)."""
from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np

import cressim


def save_png(path, image) -> Path:
    """Writes an 8-bit PNG: image (H, W) grey, (H, W, 3) RGB or (H, W, 4) RGBA, uint8 (or a
    torch tensor / cressim buffer view that numpy can read). Returns the path."""
    a = np.ascontiguousarray(np.asarray(image))
    if a.dtype != np.uint8:
        raise ValueError(f"save_png: {path}: the image must be uint8, not {a.dtype}")
    if a.ndim == 2:
        a = a[:, :, None]
    if a.ndim != 3 or a.shape[2] not in (1, 3, 4):
        raise ValueError(f"save_png: {path}: the image must be (H, W), (H, W, 3) or (H, W, 4), not {a.shape}")
    h, w, c = a.shape
    colour_type = {1: 0, 3: 2, 4: 6}[c]
    rows = np.concatenate([np.zeros((h, 1), np.uint8), a.reshape(h, w * c)], axis=1)  # filter 0 per row

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    png = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, colour_type, 0, 0, 0))
           + chunk(b"IDAT", zlib.compress(rows.tobytes(), 6)) + chunk(b"IEND", b""))
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(png)
    return path


def read_png(path) -> np.ndarray:
    """(H, W, C) uint8 of a PNG file (through matplotlib's reader)."""
    import matplotlib.image

    a = matplotlib.image.imread(str(path))
    return a if a.dtype == np.uint8 else np.round(np.clip(a, 0, 1) * 255).astype(np.uint8)


def colour_depth(depth, near: float | None = None, far: float | None = None) -> np.ndarray:
    """(H, W) metric depth -> (H, W, 3) uint8: near red, far blue (matplotlib's 'turbo'), 0
    (nothing hit) black. near/far default to the hit pixels' range."""
    from matplotlib import colormaps

    d = np.asarray(depth, dtype=np.float32)
    hit = d > 0
    out = np.zeros((*d.shape, 3), np.uint8)
    if not hit.any():
        return out
    lo = float(d[hit].min()) if near is None else near
    hi = float(d[hit].max()) if far is None else far
    t = 1 - np.clip((d - lo) / max(hi - lo, 1e-9), 0, 1)
    rgb = colormaps["turbo"](t[hit])[:, :3]
    out[hit] = np.round(rgb * 255).astype(np.uint8)
    return out


def colour_segmentation(seg) -> np.ndarray:
    """(H, W) segmentation ids -> (H, W, 3) uint8: one stable colour per id (golden-ratio hues),
    0 (background) black."""
    s = np.asarray(seg).astype(np.uint64)
    hue = (s * 0.6180339887) % 1.0
    h6 = hue * 6
    k = np.floor(h6).astype(np.int64) % 6
    f = h6 - np.floor(h6)
    v, lo = 0.95, 0.25  # value and the floor of the other channels
    q, t = v - (v - lo) * f, lo + (v - lo) * f
    table = [(v, t, lo), (q, v, lo), (lo, v, t), (lo, q, v), (t, lo, v), (v, lo, q)]
    rgb = np.zeros((*s.shape, 3))
    for i, (r, g, b) in enumerate(table):
        m = k == i
        for ch, x in enumerate((r, g, b)):
            rgb[..., ch][m] = (x[m] if np.ndim(x) else x)
    rgb[s == 0] = 0
    return np.round(rgb * 255).astype(np.uint8)


def load_mesh(path, *, scale: float = 1.0) -> cressim.Mesh:
    """A .obj/.stl/.glb/.ply (anything trimesh reads) as a cressim.Mesh: the file's meshes
    merged, vertex normals from the file or computed, uvs when the file has them (v flipped to
    the image's rows-down convention)."""
    import trimesh

    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"load_mesh: no such file: {path}")
    m = trimesh.load(str(path), force="mesh", process=False)
    if not isinstance(m, trimesh.Trimesh) or len(m.faces) == 0:
        raise ValueError(f"load_mesh: {path}: no triangles in the file")
    uvs = getattr(m.visual, "uv", None)
    if uvs is not None and len(uvs) == len(m.vertices):
        uvs = np.column_stack([uvs[:, 0], 1.0 - uvs[:, 1]]).astype(np.float32)
    else:
        uvs = None
    return cressim.Mesh(np.asarray(m.vertices, np.float32) * scale, np.asarray(m.faces, np.uint32),
                        np.asarray(m.vertex_normals, np.float32), uvs)


def load_mesh_texture(path) -> cressim.Texture | None:
    """The base-colour image a mesh file carries (a .glb's material, an .obj's map_Kd), or None."""
    import trimesh

    m = trimesh.load(str(path), force="mesh", process=False)
    material = getattr(m.visual, "material", None)
    image = getattr(material, "baseColorTexture", None) or getattr(material, "image", None)
    if image is None:
        return None
    return cressim.Texture(np.asarray(image.convert("RGBA"), np.uint8))


def load_texture(path) -> cressim.Texture:
    """A PNG file as a cressim.Texture."""
    return cressim.Texture(read_png(path))


def checker_texture(size: int = 64, squares: int = 8, colors=((230, 230, 230), (40, 40, 40))) -> cressim.Texture:
    """A checkerboard texture, `squares` a side."""
    i = (np.arange(size) * squares // size)
    mask = (i[:, None] + i[None, :]) % 2 == 0
    img = np.where(mask[..., None], np.array(colors[0], np.uint8), np.array(colors[1], np.uint8))
    return cressim.Texture(img.astype(np.uint8))
