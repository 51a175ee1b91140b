"""Every camera's images on the host after a rendered frame (one per env, or a cart's two eyes): colour (rgb8), depth (metres,
NaN where nothing was hit, REP 118) and segmentation ids (uint16), in env order. One copy per
product and camera group; what the ROS camera topics and the twin benchmark publish.
"""
from __future__ import annotations

import numpy as np

PRODUCTS = ("color", "depth", "segmentation")
BUFFERS = {"color": "rgb", "depth": "depth", "segmentation": "segmentation"}


class CameraImages:
    def __init__(self, engine):
        self.engine = engine
        cams = engine.cameras
        # each camera's (group, layer), by env and then as authored (a cart's left eye, then its
        # right): images of camera k are camera{group}.*[layer]
        order = np.argsort(cams["env"], kind="stable")
        self.where = [(int(cams["group"][k]), int(cams["layer"][k])) for k in order]
        self.groups = sorted({g for g, _ in self.where})

    def read(self, products) -> dict:
        """product -> [per env (H, W, ...) numpy image]."""
        return self.convert(self.grab(products))

    def grab(self, products) -> dict:
        """The raw outputs on the host: {product: {group: array}}. Call right after the frame
        (the next frame overwrites them); `convert` can run later, without the engine."""
        return {product: {g: self.engine.buffer(f"camera{g}.{BUFFERS[product]}").read() for g in self.groups}
                for product in PRODUCTS if product in products}

    def convert(self, raw: dict) -> dict:
        out = {}
        for product, per_group in raw.items():
            images = {}
            for g, a in per_group.items():
                if product == "color":
                    a = a[..., :3]
                elif product == "segmentation":
                    a = np.minimum(a, 65535).astype(np.uint16)
                else:
                    a = np.where(a == 0, np.float32(np.nan), a)
                images[g] = a
            out[product] = [images[g][layer] for g, layer in self.where]
        return out


__all__ = ["BUFFERS", "PRODUCTS", "CameraImages"]
