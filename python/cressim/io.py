"""Files in and out of the renderer: PNG images and OpenEXR images (small zlib writers, no
imaging library), H.264 MP4 videos (PyAV, imported when used), depth and segmentation colour maps for
people to look at, and meshes and textures read from .obj/.stl/.glb/.png files (trimesh and
matplotlib, imported when used)."""
from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np

# the binding itself, not the `cressim` facade: the facade's sensors import this module
from cressim._core import Mesh, Texture


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


_EXR_HALF, _EXR_FLOAT = 1, 2  # OpenEXR pixel types (0 is uint)
_EXR_LINES = 16  # scanlines per chunk under ZIP compression (the format fixes it)


def save_exr(path, image=None, *, depth=None, half: bool = True, compress: bool = True) -> Path:
    """Writes an OpenEXR scanline image (ZIP-compressed, or uncompressed with compress=False).

    image: (H, W, 3) or (H, W, 4) colour, channels R G B [A]. uint8 is a camera's "rgb" tensor
    (sRGB-encoded, gamma 2.2 as the renderer writes it): decoded to linear, since EXR holds
    linear values; float is taken as linear. Stored as half (or float with half=False).
    depth: (H, W) metric depth, a camera's "depth" tensor: channel Z, float32 metres; the
    tensor's 0 (nothing hit) is written as +inf. Either or both (same H, W). Returns the path."""
    channels = {}  # name -> (H, W) array of the stored type
    if image is not None:
        a = np.asarray(image)
        if a.ndim != 3 or a.shape[2] not in (3, 4):
            raise ValueError(f"save_exr: {path}: the image must be (H, W, 3) or (H, W, 4), not {a.shape}")
        if a.dtype == np.uint8:
            f = (a.astype(np.float32) / 255)
            f[..., :3] **= 2.2
        elif np.issubdtype(a.dtype, np.floating):
            f = a.astype(np.float32)
        else:
            raise ValueError(f"save_exr: {path}: the image must be uint8 or float, not {a.dtype}")
        for i, name in enumerate("RGBA"[:a.shape[2]]):
            channels[name] = f[..., i].astype(np.float16 if half else np.float32)
    if depth is not None:
        d = np.array(depth, dtype=np.float32)
        if d.ndim != 2:
            raise ValueError(f"save_exr: {path}: depth must be (H, W), not {d.shape}")
        d[d <= 0] = np.inf
        channels["Z"] = d
    if not channels:
        raise ValueError(f"save_exr: {path}: give an image, a depth or both")
    shapes = {c.shape[:2] for c in channels.values()}
    if len(shapes) != 1:
        raise ValueError(f"save_exr: {path}: image and depth differ in size: {sorted(shapes)}")
    (h, w), = shapes
    names = sorted(channels)  # the format stores channels in name order

    def attribute(name: str, kind: str, value: bytes) -> bytes:
        return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(value)) + value

    chlist = b"".join(n.encode() + b"\0" + struct.pack("<iB3xii", _EXR_HALF if channels[n].dtype == np.float16
                                                          else _EXR_FLOAT, 0, 1, 1) for n in names) + b"\0"
    window = struct.pack("<iiii", 0, 0, w - 1, h - 1)
    header = (attribute("channels", "chlist", chlist)
              + attribute("compression", "compression", bytes([3 if compress else 0]))
              + attribute("dataWindow", "box2i", window) + attribute("displayWindow", "box2i", window)
              + attribute("lineOrder", "lineOrder", b"\0")  # increasing y
              + attribute("pixelAspectRatio", "float", struct.pack("<f", 1))
              + attribute("screenWindowCenter", "v2f", struct.pack("<ff", 0, 0))
              + attribute("screenWindowWidth", "float", struct.pack("<f", 1)) + b"\0")
    lines = _EXR_LINES if compress else 1
    chunks = []
    for y0 in range(0, h, lines):
        # a chunk: per scanline, each channel's row in turn (little-endian)
        rows = np.concatenate([channels[n][y0:y0 + lines].astype(channels[n].dtype.newbyteorder("<"))
                               .view(np.uint8).reshape(-1, w * channels[n].itemsize) for n in names], axis=1)
        data = rows.tobytes()
        if compress:
            packed = _exr_zip(data)
            data = packed if len(packed) < len(data) else data  # readers take a full-size chunk as raw
        chunks.append(struct.pack("<ii", y0, len(data)) + data)
    start = 8 + len(header) + 8 * len(chunks)
    offsets = np.cumsum([start] + [len(c) for c in chunks[:-1]]).astype("<u8")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(struct.pack("<ii", 20000630, 2) + header + offsets.tobytes() + b"".join(chunks))
    return path


def _exr_zip(data: bytes) -> bytes:
    """OpenEXR's ZIP chunk: bytes split into even and odd halves, then byte deltas (+128), then zlib."""
    b = np.frombuffer(data, np.uint8)
    t = np.concatenate([b[0::2], b[1::2]])
    d = t.copy()
    d[1:] = (t[1:].astype(np.int16) - t[:-1] + 128).astype(np.uint8)
    return zlib.compress(d.tobytes(), 6)


def read_png(path) -> np.ndarray:
    """(H, W, C) uint8 of a PNG file (through matplotlib's reader)."""
    import matplotlib.image

    a = matplotlib.image.imread(str(path))
    return a if a.dtype == np.uint8 else np.round(np.clip(a, 0, 1) * 255).astype(np.uint8)


def write_mp4(path, frames, fps: float, *, lossless: bool = False) -> Path:
    """Writes `frames` ((T, H, W, 3) uint8) as an H.264 MP4 at `fps`; returns the path. Default
    yuv420p, which every player reads (H and W even); `lossless`: constant quality 0 in yuv444p, so
    that the frames decode back within one level (RGB <-> YUV rounding), for datasets."""
    import fractions

    import av

    frames = np.asarray(frames)
    if frames.ndim != 4 or frames.shape[-1] != 3 or frames.dtype != np.uint8 or len(frames) == 0:
        raise ValueError(f"write_mp4: {path}: frames must be (T > 0, H, W, 3) uint8, got {frames.shape} {frames.dtype}")
    if not lossless and (frames.shape[1] % 2 or frames.shape[2] % 2):
        raise ValueError(f"write_mp4: {path}: yuv420p needs an even width and height, got {frames.shape[1:3]}")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with av.open(str(path), "w") as container:
        stream = container.add_stream("libx264", rate=fractions.Fraction(fps).limit_denominator(1000))
        stream.height, stream.width = frames.shape[1:3]
        stream.pix_fmt = "yuv444p" if lossless else "yuv420p"
        if lossless:
            stream.options = {"qp": "0", "preset": "veryfast"}
        for image in frames:
            container.mux(stream.encode(av.VideoFrame.from_ndarray(np.ascontiguousarray(image), format="rgb24")))
        container.mux(stream.encode())  # flush the encoder
    return path


def read_mp4(path) -> np.ndarray:
    """A video's frames, (T, H, W, 3) uint8."""
    import av

    with av.open(str(path)) as container:
        return np.stack([frame.to_ndarray(format="rgb24") for frame in container.decode(video=0)])


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


def load_mesh(path, *, scale: float = 1.0) -> Mesh:
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
    return Mesh(np.asarray(m.vertices, np.float32) * scale, np.asarray(m.faces, np.uint32),
                        np.asarray(m.vertex_normals, np.float32), uvs)


def load_mesh_texture(path, which: str = "color") -> Texture | None:
    """An image a mesh file carries, or None. which="color": the base colour (a .glb's material,
    an .obj's map_Kd); "normal": a .glb's normal map (glTF's convention is ours: green toward the
    image's top), for Renderable(normal_map=...)."""
    import trimesh

    if which not in ("color", "normal"):
        raise ValueError(f"load_mesh_texture(which={which!r}): use 'color' or 'normal'")
    m = trimesh.load(str(path), force="mesh", process=False)
    material = getattr(m.visual, "material", None)
    if which == "normal":
        image = getattr(material, "normalTexture", None)
    else:
        image = getattr(material, "baseColorTexture", None) or getattr(material, "image", None)
    if image is None:
        return None
    return Texture(np.asarray(image.convert("RGBA"), np.uint8))


def load_texture(path) -> Texture:
    """A PNG file as a cressim.Texture."""
    return Texture(read_png(path))


def checker_texture(size: int = 64, squares: int = 8, colors=((230, 230, 230), (40, 40, 40))) -> Texture:
    """A checkerboard texture, `squares` a side."""
    i = (np.arange(size) * squares // size)
    mask = (i[:, None] + i[None, :]) % 2 == 0
    img = np.where(mask[..., None], np.array(colors[0], np.uint8), np.array(colors[1], np.uint8))
    return Texture(img.astype(np.uint8))
