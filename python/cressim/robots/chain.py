"""One kinematics for every arm: a URDF kinematic tree compiled once, with two backends.

    chain = Chain("psm_lnd.urdf", sources=PSM_JOINTS + ("jaw",), tip="PSM1_tool_tip_link")
    T = chain.forward(q)                # (..., C) -> (..., 4, 4): the tip in the base link
    J, T = chain.jacobian(q)            # (..., 6, C): [v; w] of the tip point, base axes
    poses = chain.link_poses(q)         # (..., L, 4, 4): every link (chain.links order)
    steps, ranges = chain.steps(links)  # the HLSL backend's table (link_poses.hlsl)

q has one column per *source* (the arm's joint values, in the caller's order); every moving URDF
joint reads one column as gain x value + offset, so mimic joints (the PSM's parallelogram, its
jaw blades) follow their source. Fixed, revolute, continuous and prismatic joints; a fixed tip
offset after the tip link.

Compiled once: fixed joints are folded into the next moving joint's origin, and each moving
joint's transform is origin @ (I + sin(v) A + (1 - cos(v)) B + v C) with constant A, B, C (a
rotation about the axis or a shift along it), folded with the origin. A batch then costs a
handful of tensor ops plus one matrix product per moving joint on the way: the twin computes FK
and the Jacobian of a few arms every tick, where per-link tensor code costs a hundred small ops.
Torch tensors keep their dtype and device; numpy in gives numpy out (float64).
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Sequence

import numpy as np
import torch
import yourdfpy

FIXED, REVOLUTE, PRISMATIC = 0, 1, 2
_TYPES = {"fixed": FIXED, "revolute": REVOLUTE, "continuous": REVOLUTE, "prismatic": PRISMATIC}


def _skew(a) -> np.ndarray:
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def rotation_xyzw(R) -> tuple:
    """x, y, z, w (the engine's quaternion order) of a 3x3 rotation matrix; Shepperd's method."""
    R = np.asarray(R, dtype=np.float64)
    tr = R[0, 0] + R[1, 1] + R[2, 2]
    k = int(np.argmax([tr, R[0, 0], R[1, 1], R[2, 2]]))
    if k == 0:
        w = np.sqrt(1.0 + tr) / 2
        q = ((R[2, 1] - R[1, 2]) / (4 * w), (R[0, 2] - R[2, 0]) / (4 * w), (R[1, 0] - R[0, 1]) / (4 * w), w)
    else:
        i, j, m = k - 1, k % 3, (k + 1) % 3
        r = np.sqrt(1.0 + R[i, i] - R[j, j] - R[m, m])
        v = [0.0, 0.0, 0.0]
        v[i], v[j], v[m] = r / 2, (R[j, i] + R[i, j]) / (2 * r), (R[m, i] + R[i, m]) / (2 * r)
        q = (*v, (R[m, j] - R[j, m]) / (2 * r))
    if q[3] < 0:
        q = tuple(-c for c in q)
    return tuple(float(c) for c in q)


class Chain:
    """A URDF's links from `base` down (all of them, or `links`), compiled once.

    `sources`: the names of q's columns; default the URDF's actuated (non-mimic) joints in URDF
    order. A name no joint reads is allowed (a column of zeros in the Jacobian: a wrist-less
    tool in the 6-joint interface). `tip`: the link whose pose `forward` and `jacobian` give,
    times `tip_offset` (4x4) when given. `links`: the links `link_poses` gives (default every
    link); only the joints on their way (and the tip's) are compiled.
    """

    def __init__(self, urdf, *, sources: Sequence[str] | None = None, base: str | None = None,
                 tip: str | None = None, tip_offset=None, links: Sequence[str] | None = None):
        if not isinstance(urdf, yourdfpy.URDF):
            urdf = yourdfpy.URDF.load(str(urdf), build_scene_graph=False, load_meshes=False)
        self.urdf = urdf
        joints = {j.name: j for j in urdf.robot.joints}
        self.sources = tuple(sources) if sources is not None else tuple(urdf.actuated_joint_names)
        roots = [l.name for l in urdf.robot.links if l.name not in {j.child for j in urdf.robot.joints}]
        self.base = base or roots[0]
        # with `links` (or only a tip), only the joints on their way are compiled: the rest of the
        # tree (a jaw the caller has no value for) is not needed
        wanted = None if links is None else {*links, *([tip] if tip else [])}
        if wanted is not None:
            parent_of = {j.child: j.parent for j in urdf.robot.joints}
            for name in list(wanted):
                while name in parent_of:
                    name = parent_of[name]
                    wanted.add(name)
        children = {}
        for j in urdf.robot.joints:
            if wanted is None or j.child in wanted:
                children.setdefault(j.parent, []).append(j)

        # one walk of the tree: moving joints in topological order, each with the frame it hangs
        # from (0 the base, i + 1 moving joint i) and the fixed transform from there to its origin
        self.joint_names, self.joint_types, self.joint_links, self._parent, self._pre = [], [], [], [], []
        self.axes, self.columns, self.gains, self.offsets = [], [], [], []  # axis in the joint's frame
        link_at = {self.base: (0, np.eye(4))}  # link -> (frame, constant from that frame)
        stack = [self.base]
        while stack:
            link = stack.pop()
            frame, const = link_at[link]
            for j in reversed(children.get(link, [])):
                kind = _TYPES.get(j.type)
                if kind is None:
                    raise ValueError(f"URDF joint {j.name}: type {j.type!r} is not fixed, revolute, continuous or prismatic")
                origin = const @ (j.origin if j.origin is not None else np.eye(4))
                if kind == FIXED:
                    link_at[j.child] = (frame, origin)
                else:
                    mimic = j.mimic
                    source, gain, offset = ((mimic.joint, mimic.multiplier if mimic.multiplier is not None else 1.0,
                                             mimic.offset or 0.0) if mimic else (j.name, 1.0, 0.0))
                    if source not in self.sources:
                        raise ValueError(f"URDF joint {j.name} moves with {source}, which is not one of the "
                                         f"sources {', '.join(self.sources)}")
                    axis = np.asarray(j.axis if j.axis is not None else (1.0, 0.0, 0.0), np.float64)
                    self.joint_names.append(j.name)
                    self.joint_links.append(j.child)
                    self.joint_types.append(kind)
                    self._parent.append(frame)
                    self._pre.append(origin)
                    self.axes.append(axis / np.linalg.norm(axis))
                    self.columns.append(self.sources.index(source))
                    self.gains.append(float(gain))
                    self.offsets.append(float(offset))
                    link_at[j.child] = (len(self.joint_names), np.eye(4))
                stack.append(j.child)
        self.joint_names, self.joint_types, self.joint_links = (tuple(x) for x in (
            self.joint_names, self.joint_types, self.joint_links))
        self.links = tuple(links) if links is not None else tuple(n for n in link_at)
        missing = [n for n in self.links if n not in link_at]
        if missing:
            raise ValueError(f"links {missing} are not below {self.base}")
        self._link_frame = [link_at[n][0] for n in self.links]
        self._link_const = np.stack([link_at[n][1] for n in self.links]) if self.links else np.zeros((0, 4, 4))
        self._link_at = link_at

        # per source column: the URDF limits of its own joint (nan where no URDF joint is it)
        limit = [joints[n].limit if n in joints else None for n in self.sources]
        self.lower = np.array([l.lower if l is not None and l.lower is not None else np.nan for l in limit])
        self.upper = np.array([l.upper if l is not None and l.upper is not None else np.nan for l in limit])
        self.velocity = np.array([l.velocity if l is not None and l.velocity is not None else np.nan for l in limit])
        self.effort = np.array([l.effort if l is not None and l.effort is not None else np.nan for l in limit])

        # the moving joint's transform: pre @ (I + s A + (1 - c) B + v C)
        n = len(self.joint_names)
        A, B, C = np.zeros((n, 4, 4)), np.zeros((n, 4, 4)), np.zeros((n, 4, 4))
        for i, (kind, a) in enumerate(zip(self.joint_types, self.axes)):
            if kind == REVOLUTE:
                K = _skew(a)
                A[i, :3, :3], B[i, :3, :3] = K, K @ K
            else:
                C[i, :3, 3] = a
        pre = np.stack(self._pre) if n else np.zeros((0, 4, 4))
        self._parts = np.stack([pre, pre @ A, pre @ B, pre @ C], 1) if n else np.zeros((0, 4, 4, 4))
        G = np.zeros((n, len(self.sources)))
        G[np.arange(n), self.columns] = self.gains
        self._G = G
        self._revolute = np.array([k == REVOLUTE for k in self.joint_types], dtype=np.float64)

        # the tip: the moving joints on its way from the base (ancestors first)
        self.tip = tip
        self.tip_offset = None if tip_offset is None else np.asarray(tip_offset, dtype=np.float64)
        if tip is not None:
            if tip not in link_at:
                raise ValueError(f"tip link {tip!r} is not below {self.base}")
            frame, const = link_at[tip]
            self._tip_const = const if self.tip_offset is None else const @ self.tip_offset
            path = []
            while frame:
                path.append(frame - 1)
                frame = self._parent[frame - 1]
            self.tip_path = tuple(reversed(path))
        self._jumps = _jumps(self._parent)
        self._on = {}  # (dtype, device, key) -> constants as tensors there

    def __repr__(self):
        return f"Chain({self.base} -> {self.tip}, {len(self.joint_names)} moving joints, sources {self.sources})"

    # ------------------------------------------------------------------ compiled constants
    def _const(self, key, like: torch.Tensor):
        at = (like.dtype, like.device, key)
        if at not in self._on:
            if key == "path":
                idx = list(self.tip_path)
                data = dict(parts=self._parts[idx], G=self._G[idx], rev=self._revolute[idx],
                            axis=np.stack([self.axes[i] for i in idx]) if idx else np.zeros((0, 3)),
                            tip=self._tip_const, offset=np.asarray([self.offsets[i] for i in idx]))
                jumps = _jumps(list(range(len(idx))))  # the way is serial: each hangs from the one before
            else:
                data = dict(parts=self._parts, G=self._G, link=self._link_const, offset=np.asarray(self.offsets))
                jumps = self._jumps
            self._on[at] = {k: torch.as_tensor(v, dtype=like.dtype, device=like.device) for k, v in data.items()}
            self._on[at]["jumps"] = [torch.as_tensor(j, device=like.device) for j in jumps]
        return self._on[at]

    @staticmethod
    def _io(q):
        if torch.is_tensor(q):
            return q, False
        return torch.as_tensor(np.asarray(q, dtype=np.float64)), True

    def _check(self, q):
        if q.shape[-1] != len(self.sources):
            raise ValueError(f"expected (..., {len(self.sources)}) values of {self.sources}, got {tuple(q.shape)}")

    def values(self, q):
        """(..., C) -> (..., J): every moving URDF joint's value (chain.joint_names), mimic joints
        included: what robot_state_publisher reads from /joint_states."""
        qt, was_numpy = self._io(q)
        self._check(qt)
        G = torch.as_tensor(self._G, dtype=qt.dtype, device=qt.device)
        v = qt @ G.T + torch.as_tensor(self.offsets, dtype=qt.dtype, device=qt.device)
        return v.numpy() if was_numpy else v

    @staticmethod
    def _frames(q, c):
        """(M, 1 + J, 4, 4): the base (identity) and the moving joints of `c` after their motion.

        Each joint's transform from the frame it hangs from, then pointer jumping: every frame
        times the one it hangs from, which then hangs from that one's parent, ... : log2(depth)
        batched products instead of one per joint."""
        v = q @ c["G"].T + c["offset"]  # (M, J)
        coef = torch.stack([torch.ones_like(v), torch.sin(v), 1.0 - torch.cos(v), v], -1)
        local = torch.einsum("mjk,jkab->mjab", coef, c["parts"])
        F = torch.cat([torch.eye(4, dtype=q.dtype, device=q.device).expand(q.shape[0], 1, 4, 4), local], 1)
        for parent in c["jumps"]:
            F = F[:, parent] @ F
        return F

    # ------------------------------------------------------------------ torch backend
    def forward(self, q):
        """(..., C) -> (..., 4, 4): the tip (times tip_offset) in the base link."""
        return self._tip(q, jacobian=False)

    def jacobian(self, q):
        """(..., C) -> (J (..., 6, C), T (..., 4, 4)): the geometric Jacobian [v; w] of the tip point
        in base-link axes, and the tip's pose."""
        return self._tip(q, jacobian=True)

    def _tip(self, q, jacobian):
        if self.tip is None:
            raise ValueError("this chain has no tip link")
        qt, was_numpy = self._io(q)
        self._check(qt)
        lead = qt.shape[:-1]
        qt = qt.reshape(-1, qt.shape[-1])
        c = self._const("path", qt)
        F = self._frames(qt, c)[:, 1:]  # (M, J, 4, 4)
        tip = F[:, -1] @ c["tip"] if F.shape[1] else c["tip"].expand(qt.shape[0], 4, 4)
        if not jacobian:
            tip = tip.reshape(*lead, 4, 4)
            return tip.numpy() if was_numpy else tip
        if F.shape[1]:
            z = (F[..., :3, :3] @ c["axis"][..., None])[..., 0]  # joint axes in the base (M, J, 3)
            lever = tip[:, None, :3, 3] - F[..., :3, 3]
            rev = c["rev"][:, None]
            v = rev * torch.linalg.cross(z, lever, dim=-1) + (1.0 - rev) * z
            Jj = torch.cat([v, rev * z], dim=-1).transpose(-1, -2)  # (M, 6, J)
            J = Jj @ c["G"]  # chain rule through the mimic joints
        else:
            J = qt.new_zeros(qt.shape[0], 6, len(self.sources))
        J, tip = J.reshape(*lead, 6, len(self.sources)), tip.reshape(*lead, 4, 4)
        return (J.numpy(), tip.numpy()) if was_numpy else (J, tip)

    def link_poses(self, q):
        """(..., C) -> (..., L, 4, 4): every link of chain.links in the base link."""
        qt, was_numpy = self._io(q)
        self._check(qt)
        lead = qt.shape[:-1]
        qt = qt.reshape(-1, qt.shape[-1])
        c = self._const("all", qt)
        F = self._frames(qt, c)[:, self._link_frame] @ c["link"]
        F = F.reshape(*lead, len(self.links), 4, 4)
        return F.numpy() if was_numpy else F

    def link_pose(self, link: str, q):
        """(..., C) -> (..., 4, 4): one link's pose in the base link (one of chain.links)."""
        if link not in self.links:
            raise ValueError(f"link {link!r} is not one of this chain's links {self.links}")
        return self.link_poses(q)[..., self.links.index(link), :, :]

    # ------------------------------------------------------------------ HLSL backend
    def steps(self, links: Sequence[str], rotation=rotation_xyzw) -> tuple[np.ndarray, np.ndarray]:
        """The table link_poses.hlsl walks: steps ((S, 4, 4) float32) and each link's (first step,
        count) ((L, 2) uint32). A step is 4 float4: (origin xyz, type: 0 fixed, 1 revolute,
        2 prismatic), origin quaternion (xyzw), (axis xyz, gain), (source column, offset, -, -).
        Each link's steps: the moving joints on its way (fixed joints folded into their origins),
        then one fixed step to the link."""
        steps, ranges = [], []

        def step(origin, kind=FIXED, axis=(0.0, 0.0, 0.0), gain=0.0, column=0, offset=0.0):
            s = np.zeros((4, 4), np.float64)
            s[0, :3], s[0, 3] = origin[:3, 3], kind
            s[1] = rotation(origin[:3, :3])
            s[2, :3], s[2, 3] = axis, gain
            s[3, 0], s[3, 1] = column, offset
            return s

        for link in links:
            if link not in self._link_at:
                raise ValueError(f"link {link!r} is not below {self.base}")
            frame, const = self._link_at[link]
            path = []
            while frame:
                path.append(frame - 1)
                frame = self._parent[frame - 1]
            first = len(steps)
            for i in reversed(path):
                steps.append(step(self._pre[i], self.joint_types[i], self.axes[i], self.gains[i], self.columns[i],
                                  self.offsets[i]))
            steps.append(step(const))
            ranges.append((first, len(steps) - first))
        return (np.asarray(steps, np.float32).reshape(-1, 4, 4), np.asarray(ranges, np.uint32).reshape(-1, 2))


def _jumps(parent: Sequence[int]) -> list[np.ndarray]:
    """Pointer jumping's schedule for frames 1..J hanging from parent[i] (0: the base): the index
    each frame is multiplied by at each round (the base hangs from itself)."""
    p = np.array([0, *parent], dtype=np.int64)
    rounds = []
    while (p != 0).any():
        rounds.append(p.copy())
        p = p[p]
    return rounds


def load_urdf(path: str | os.PathLike) -> yourdfpy.URDF:
    """A URDF without meshes (kinematics and primitives only)."""
    return yourdfpy.URDF.load(str(Path(path)), build_scene_graph=False, load_meshes=False)


__all__ = ["Chain", "FIXED", "PRISMATIC", "REVOLUTE", "load_urdf", "rotation_xyzw"]
