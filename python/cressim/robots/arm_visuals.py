"""The visual geometry of a URDF's links as one mesh per engine body, for cameras.

Each body (a group of links that move together) gets the URDF visual geometry of its links
(box, cylinder, sphere, or a mesh file through trimesh) merged into one mesh in the body's
frame, coloured by the first link's material; built once and shared by all envs.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh


def _geometry_mesh(geometry, urdf_dir: Path):
    if geometry.box is not None:
        return _unmerged_box(geometry.box.size)
    if geometry.cylinder is not None:
        return trimesh.creation.cylinder(radius=geometry.cylinder.radius, height=geometry.cylinder.length, sections=32)
    if geometry.sphere is not None:
        return trimesh.creation.icosphere(subdivisions=2, radius=geometry.sphere.radius)
    if geometry.mesh is not None:
        mesh = trimesh.load(urdf_dir / geometry.mesh.filename, force="mesh")
        if geometry.mesh.scale is not None:
            mesh.apply_scale(geometry.mesh.scale)
        return mesh
    return None


def _unmerged_box(extents):
    box = trimesh.creation.box(extents=extents)
    box.unmerge_vertices()  # faceted: each face its own vertices, so normals are the faces'
    return box


class ArmVisuals:
    """The merged visual mesh and colour of each arm body, built once and shared by all envs."""

    def __init__(self, urdf, urdf_dir: Path, bodies, link_poses):
        colors = {m.name: tuple(m.color.rgba) for m in urdf.robot.materials if m.color is not None}
        self.meshes, self.colors, self.names = [], [], []
        for b in bodies:
            parts, color = [], None
            for link in b.links:
                rel = np.linalg.solve(b.pose, link_poses[link.name])
                for v in link.visuals:
                    mesh = _geometry_mesh(v.geometry, urdf_dir)
                    if mesh is None:
                        continue
                    mesh.apply_transform(rel @ (v.origin if v.origin is not None else np.eye(4)))
                    parts.append(mesh)
                    if color is None and v.material is not None:
                        rgba = v.material.color.rgba if v.material.color is not None else colors.get(v.material.name)
                        color = tuple(float(c) for c in rgba) if rgba is not None else None
            self.meshes.append(trimesh.util.concatenate(parts) if parts else None)
            self.colors.append(color or (0.6, 0.6, 0.6, 1.0))
            self.names.append(b.name)


__all__ = ["ArmVisuals"]
