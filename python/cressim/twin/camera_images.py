"""Every env's camera images on the host after a rendered frame: colour (rgb8), depth (metres,
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
        # env -> (group, layer) of its camera: images of env i are camera{group}.*[layer]
        order = np.argsort(cams["env"])
        self.where = [(int(cams["group"][k]), int(cams["layer"][k])) for k in order]
        self.groups = sorted({g for g, _ in self.where})

    def read(self, products) -> dict:
        """product -> [per env (H, W, ...) numpy image]."""
        out = {}
        for product in (p for p in PRODUCTS if p in products):
            per_group = {}
            for g in self.groups:
                a = self.engine.buffer(f"camera{g}.{BUFFERS[product]}").read()
                if product == "color":
                    a = a[..., :3]
                elif product == "segmentation":
                    a = np.minimum(a, 65535).astype(np.uint16)
                else:
                    a = np.where(a == 0, np.float32(np.nan), a)
                per_group[g] = a
            out[product] = [per_group[g][layer] for g, layer in self.where]
        return out


__all__ = ["BUFFERS", "PRODUCTS", "CameraImages"]
