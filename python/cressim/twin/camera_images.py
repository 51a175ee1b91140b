"""Every camera's images on the host after a rendered frame (one per env, or a cart's two eyes): colour (rgb8), depth (metres,
NaN where nothing was hit, REP 118) and segmentation ids (uint16), in env order. One readback per
frame for every product and camera (cressim.read_buffers: one submit, into host arrays kept from
frame to frame); what the ROS camera topics and the twin benchmark publish.

    images = CameraImages(engine)
    raw = images.grab(["color", "depth"])     # right after the frame, engine lock held
    out = images.convert(raw)                 # later, without the engine: fresh arrays ...
    images.convert(raw, out=messages)         # ... or into the caller's (a message's buffer)
"""
from __future__ import annotations

import numpy as np

import cressim

PRODUCTS = ("color", "depth", "segmentation")
BUFFERS = {"color": "rgb", "depth": "depth", "segmentation": "segmentation"}
DTYPES = {"color": np.uint8, "depth": np.float32, "segmentation": np.uint16}  # as published


class CameraImages:
    def __init__(self, engine):
        self.engine = engine
        cams = engine.cameras
        # each camera's (group, layer), by env and then as authored (a cart's left eye, then its
        # right): images of camera k are camera{group}.*[layer]
        order = np.argsort(cams["env"], kind="stable")
        self.where = [(int(cams["group"][k]), int(cams["layer"][k])) for k in order]
        self.groups = sorted({g for g, _ in self.where})
        self._raw = {}  # (product, group) -> the host array a frame is read into (reused)

    def grab(self, products) -> dict:
        """The raw outputs on the host: {product: {group: array}}, one readback for all. Call right
        after the frame; the arrays are reused by the next grab, so convert before that."""
        keys = [(p, g) for p in PRODUCTS if p in products for g in self.groups]
        buffers = [self.engine.buffer(f"camera{g}.{BUFFERS[p]}") for p, g in keys]
        for key, b in zip(keys, buffers):
            if key not in self._raw:
                self._raw[key] = np.empty(b.shape, b.dtype)
        cressim.read_buffers(buffers, [self._raw[k] for k in keys])
        raw = {}
        for p, g in keys:
            raw.setdefault(p, {})[g] = self._raw[(p, g)]
        return raw

    def read(self, products) -> dict:
        """product -> [per camera (H, W, ...) numpy image], fresh arrays."""
        return self.convert(self.grab(products))

    def convert(self, raw: dict, out: dict | None = None) -> dict:
        """product -> [per camera image]: rgb8 (H, W, 3), depth float32 with NaN, uint16 ids.
        `out` (product -> [per camera array of that shape and dtype]) receives them in one pass
        each (no intermediate copies); default: new arrays."""
        result = {}
        for product, per_group in raw.items():
            images = []
            for k, (g, layer) in enumerate(self.where):
                a = per_group[g][layer]
                shape = a.shape[:2] + ((3,) if product == "color" else ())
                dst = out[product][k] if out is not None else np.empty(shape, DTYPES[product])
                if product == "color":
                    np.copyto(dst, a[..., :3])
                elif product == "segmentation":
                    np.copyto(dst, np.minimum(a, 65535, out=a), casting="unsafe")  # the raw array is scratch
                else:
                    np.copyto(dst, a)
                    np.copyto(dst, np.float32(np.nan), where=a == 0)
                images.append(dst)
            result[product] = images
        return result


__all__ = ["BUFFERS", "DTYPES", "PRODUCTS", "CameraImages"]
