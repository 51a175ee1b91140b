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
Torch tensors keep their dtype and device; anything else is evaluated in numpy (float64) by the
same code (one arm's joint vector a tick: numpy's calls cost a third of torch's).
"""
from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Sequence

import numpy as np
import torch
import yourdfpy

FIXED, REVOLUTE, PRISMATIC = 0, 1, 2
MERGE_TOLERANCE = 1e-10  # m (and rad): a run of joints is one screw when it moves as one within this
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
                    raise ValueError(f"URDF joint {j.name}: type {j.type!r} is not fixed, revolute, continuous "
                                     "or prismatic")
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

        # per source column: the URDF limits of its own joint (nan where no URDF joint is it)
        limit = [joints[n].limit if n in joints else None for n in self.sources]
        self.lower = np.array([l.lower if l is not None and l.lower is not None else np.nan for l in limit])
        self.upper = np.array([l.upper if l is not None and l.upper is not None else np.nan for l in limit])
        self.velocity = np.array([l.velocity if l is not None and l.velocity is not None else np.nan for l in limit])
        self.effort = np.array([l.effort if l is not None and l.effort is not None else np.nan for l in limit])

        self.tip = tip
        self.tip_offset = None if tip_offset is None else np.asarray(tip_offset, dtype=np.float64)
        if tip is not None and tip not in link_at:
            raise ValueError(f"tip link {tip!r} is not below {self.base}")
        self._compile(link_at, {*self.links, *([tip] if tip else [])})
        self._on = {}  # (dtype, device, key) -> constants as tensors there

    def _compile(self, link_at, wanted):
        """The frames the backends compute: one per moving joint, turned so that it moves about (or
        along) its z; a run of joints one value drives whose links are not wanted (the PSM's
        parallelogram, for the tip) becomes one frame when its motion is one screw."""
        n = len(self.joint_names)
        frames = []  # dicts: parent (index + 1, 0 the base), pre, kind, column, gain, offset
        post = [np.eye(4)] * (n + 1)  # each frame's constant after its motion, folded into what hangs on it
        for i in range(n):
            R = _z_to(self.axes[i])
            frames.append(dict(parent=self._parent[i], pre=post[self._parent[i]] @ self._pre[i] @ R,
                               kind=self.joint_types[i], column=self.columns[i], gain=self.gains[i],
                               offset=self.offsets[i]))
            post[i + 1] = R.T
        at = {name: (f, post[f] @ const) for name, (f, const) in link_at.items()}
        # merge a run of frames into its top one: one value drives them, each but the last is its
        # parent's only child frame and carries no wanted link, and together they move as one screw
        def mergeable(f):  # frame index f (1-based): may be inside a run, or end one
            return (frames[f - 1] is not None and sum(1 for g in frames if g is not None and g["parent"] == f) == 1
                    and not any(at_f == f and name in wanted for name, (at_f, _) in at.items()))

        merged = True
        while merged:
            merged = False
            for j, fj in enumerate(frames):
                if fj is None:
                    continue
                run = [j + 1]  # frame indices, bottom up
                while True:
                    up = frames[run[-1] - 1]["parent"]
                    if not (up and frames[up - 1]["column"] == fj["column"] and mergeable(up)):
                        break
                    run.append(up)
                for top in range(len(run) - 1, 0, -1):  # the longest run first
                    chosen = run[: top + 1][::-1]
                    joint = _merge([frames[f - 1] for f in chosen])
                    if joint is None:
                        continue
                    first = chosen[0]
                    frames[first - 1] = dict(joint[0], parent=frames[first - 1]["parent"])
                    for f in frames:  # what hung on the run's end hangs on its top, after the constant
                        if f is not None and f["parent"] == j + 1:
                            f["parent"], f["pre"] = first, joint[1] @ f["pre"]
                    # links inside the run (none wanted) are gone with its frames
                    at = {name: ((first, joint[1] @ c) if f == j + 1 else (f, c)) for name, (f, c) in at.items()
                          if f not in chosen[:-1]}
                    for f in chosen[1:]:
                        frames[f - 1] = None
                    merged = True
                    break
                if merged:
                    break
        # renumber the frames left
        index = {0: 0}
        for i, f in enumerate(frames):
            if f is not None:
                index[i + 1] = len(index)
        kept = [f for f in frames if f is not None]
        self._fparent = [index[f["parent"]] for f in kept]
        self._fkind = [f["kind"] for f in kept]
        self._fcolumn = [f["column"] for f in kept]
        self._fgain = [f["gain"] for f in kept]
        self._foffset = [f["offset"] for f in kept]
        self._fpre = np.stack([f["pre"] for f in kept]) if kept else np.zeros((0, 4, 4))
        self._link_at = {name: (index[f], c) for name, (f, c) in at.items() if f in index}
        self._link_frame = [self._link_at[name][0] for name in self.links]
        self._link_const = (np.stack([self._link_at[name][1] for name in self.links]) if self.links
                            else np.zeros((0, 4, 4)))
        # the moving frame's transform: pre @ (I + sin(v) A + (1 - cos(v)) B + v C), about or along z
        m = len(kept)
        A, B, C = np.zeros((m, 4, 4)), np.zeros((m, 4, 4)), np.zeros((m, 4, 4))
        revolute = np.array([k == REVOLUTE for k in self._fkind], dtype=bool)
        A[revolute, 0, 1], A[revolute, 1, 0] = -1.0, 1.0
        B[revolute, 0, 0], B[revolute, 1, 1] = -1.0, -1.0
        C[~revolute, 2, 3] = 1.0
        pre = self._fpre
        self._parts = np.stack([pre, pre @ A, pre @ B, pre @ C], 1) if m else np.zeros((0, 4, 4, 4))
        G = np.zeros((m, len(self.sources)))
        G[np.arange(m), self._fcolumn] = self._fgain
        self._G, self._revolute = G, revolute.astype(np.float64)
        if self.tip is not None:
            frame, const = self._link_at[self.tip]
            self._tip_const = const if self.tip_offset is None else const @ self.tip_offset
            path = []
            while frame:
                path.append(frame - 1)
                frame = self._fparent[frame - 1]
            self.tip_path = tuple(reversed(path))
            G = self._G[list(self.tip_path)]
            self._path_identity = G.shape[0] == G.shape[1] and np.array_equal(G, np.eye(G.shape[0]))

    def __repr__(self):
        return f"Chain({self.base} -> {self.tip}, {len(self.joint_names)} moving joints, sources {self.sources})"

    # ------------------------------------------------------------------ compiled constants
    def _const(self, key, xp, like):
        at = (xp.name, like.dtype, getattr(like, "device", None), key)
        if at not in self._on:
            if key == "path":
                idx = list(self.tip_path)
                data = dict(parts=self._parts[idx], G=self._G[idx], rev=self._revolute[idx, None],
                            tip=self._tip_const, offset=np.asarray([self._foffset[i] for i in idx]))
            else:
                data = dict(parts=self._parts, G=self._G, link=self._link_const, offset=np.asarray(self._foffset))
            self._on[at] = {k: xp.array(v, like) for k, v in data.items()}
        return self._on[at]

    def _input(self, q):
        """(q as a (M, C) array, its leading shape, the array library): torch tensors stay torch;
        anything else is numpy float64 (one arm's vector costs a third of torch's time there)."""
        xp = _TORCH if torch.is_tensor(q) else _NUMPY
        if xp is _NUMPY:
            q = np.asarray(q, dtype=np.float64)
        if q.shape[-1] != len(self.sources):
            raise ValueError(f"expected (..., {len(self.sources)}) values of {self.sources}, got {tuple(q.shape)}")
        return q.reshape(-1, q.shape[-1]), q.shape[:-1], xp

    def values(self, q):
        """(..., C) -> (..., J): every moving URDF joint's value (chain.joint_names), mimic joints
        included: what robot_state_publisher reads from /joint_states."""
        qm, lead, xp = self._input(q)
        G = np.zeros((len(self.joint_names), len(self.sources)))
        G[np.arange(len(self.joint_names)), self.columns] = self.gains
        v = qm @ xp.array(G.T, qm) + xp.array(np.asarray(self.offsets), qm)
        return v.reshape(*lead, len(self.joint_names))

    @staticmethod
    def _locals(q, c, xp):
        """(M, J, 4, 4): each frame of `c` from the frame it hangs from, after its motion."""
        v = q @ c["G"].T + c["offset"]  # (M, J)
        coef = xp.stack([xp.ones_like(v), xp.sin(v), 1.0 - xp.cos(v), v], -1)
        return xp.einsum("mjk,jkab->mjab", coef, c["parts"])

    # ------------------------------------------------------------------ evaluation (torch or numpy)
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
        qm, lead, xp = self._input(q)
        c = self._const("path", xp, qm)
        local = self._locals(qm, c, xp)
        frames, T = [], None
        for i in range(local.shape[1]):  # the way is serial: each frame hangs from the one before
            T = local[:, i] if T is None else T @ local[:, i]
            frames.append(T)
        tip = T @ c["tip"] if T is not None else xp.expand(c["tip"], (qm.shape[0], 4, 4))
        if not jacobian:
            return tip.reshape(*lead, 4, 4)
        if frames:
            F = xp.stack(frames, 1)  # (M, J, 4, 4)
            z = F[..., :3, 2]  # every frame moves about or along its z
            lever = tip[:, None, :3, 3] - F[..., :3, 3]
            rev = c["rev"]
            v = xp.where(rev > 0, xp.cross(z, lever), z)
            J = xp.swap(xp.cat([v, rev * z], -1))
            if not self._path_identity:  # chain rule through the gains (the PSM's interface: identity)
                J = J @ c["G"]
        else:
            J = xp.zeros((qm.shape[0], 6, len(self.sources)), qm)
        return J.reshape(*lead, 6, len(self.sources)), tip.reshape(*lead, 4, 4)

    def link_poses(self, q):
        """(..., C) -> (..., L, 4, 4): every link of chain.links in the base link."""
        qm, lead, xp = self._input(q)
        c = self._const("all", xp, qm)
        local = self._locals(qm, c, xp)
        frames = [xp.expand(xp.array(np.eye(4), qm), (qm.shape[0], 4, 4))]
        for i, parent in enumerate(self._fparent):
            frames.append(frames[parent] @ local[:, i])
        F = xp.stack(frames, 1)[:, self._link_frame] @ c["link"]
        return F.reshape(*lead, len(self.links), 4, 4)

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
        Each link's steps: the compiled frames on its way (fixed joints folded into their origins),
        then one fixed step to the link."""
        steps, ranges = [], []

        def step(origin, kind=FIXED, gain=0.0, column=0, offset=0.0):
            s = np.zeros((4, 4), np.float64)
            s[0, :3], s[0, 3] = origin[:3, 3], kind
            s[1] = rotation(origin[:3, :3])
            s[2, :3], s[2, 3] = (0.0, 0.0, 1.0 if kind != FIXED else 0.0), gain
            s[3, 0], s[3, 1] = column, offset
            return s

        for link in links:
            if link not in self._link_at:
                raise ValueError(f"link {link!r} is not one of the links this chain compiled")
            frame, const = self._link_at[link]
            path = []
            while frame:
                path.append(frame - 1)
                frame = self._fparent[frame - 1]
            first = len(steps)
            for i in reversed(path):
                steps.append(step(self._fpre[i], self._fkind[i], self._fgain[i], self._fcolumn[i], self._foffset[i]))
            steps.append(step(const))
            ranges.append((first, len(steps) - first))
        return (np.asarray(steps, np.float32).reshape(-1, 4, 4), np.asarray(ranges, np.uint32).reshape(-1, 2))


class _TORCH:
    """The array operations the evaluation uses, in torch (tensors keep their dtype and device)."""
    name = "torch"
    stack, einsum, sin, cos = torch.stack, torch.einsum, torch.sin, torch.cos
    ones_like, where = torch.ones_like, torch.where

    @staticmethod
    def array(a, like):
        return torch.as_tensor(a, dtype=like.dtype, device=like.device)

    @staticmethod
    def cat(xs, dim):
        return torch.cat(xs, dim=dim)

    @staticmethod
    def cross(a, b):
        return torch.linalg.cross(a, b, dim=-1)

    @staticmethod
    def swap(x):
        return x.transpose(-1, -2)

    @staticmethod
    def expand(x, shape):
        return x.expand(*shape)

    @staticmethod
    def zeros(shape, like):
        return like.new_zeros(shape)


class _NUMPY:
    """The same operations in numpy (float64)."""
    name = "numpy"
    einsum, sin, cos, ones_like, where = np.einsum, np.sin, np.cos, np.ones_like, np.where

    @staticmethod
    def array(a, like):
        return np.asarray(a, dtype=np.float64)

    @staticmethod
    def stack(xs, dim):
        return np.stack(xs, axis=dim)

    @staticmethod
    def cat(xs, dim):
        return np.concatenate(xs, axis=dim)

    @staticmethod
    def cross(a, b):  # np.cross costs ten times this on small arrays
        a0, a1, a2, b0, b1, b2 = a[..., 0], a[..., 1], a[..., 2], b[..., 0], b[..., 1], b[..., 2]
        return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)

    @staticmethod
    def swap(x):
        return np.swapaxes(x, -1, -2)

    @staticmethod
    def expand(x, shape):
        return np.broadcast_to(x, shape)

    @staticmethod
    def zeros(shape, like):
        return np.zeros(shape)


def screw_motion(axis, point, kind, value) -> np.ndarray:
    """4x4: a turn by `value` about the axis through `point` along the unit `axis`, or a shift
    along it (kind PRISMATIC)."""
    T = np.eye(4)
    if kind == REVOLUTE:
        K = _skew(axis)
        T[:3, :3] = np.eye(3) + math.sin(value) * K + (1 - math.cos(value)) * K @ K
        T[:3, 3] = point - T[:3, :3] @ point
    else:
        T[:3, 3] = value * np.asarray(axis, dtype=np.float64)
    return T


def _z_to(axis) -> np.ndarray:
    """4x4 rotation taking z onto the unit `axis` (the least turn; a half turn about x for -z)."""
    z = np.array([0.0, 0.0, 1.0])
    n = np.cross(z, axis)
    s, c = float(np.linalg.norm(n)), float(axis[2])
    T = np.eye(4)
    if s < 1e-12:
        if c < 0:
            T[:3, :3] = np.diag([1.0, -1.0, -1.0])
        return T
    return screw_motion(n / s, np.zeros(3), REVOLUTE, math.atan2(s, c))


def _motion(kind, v) -> np.ndarray:
    return screw_motion((0.0, 0.0, 1.0), np.zeros(3), kind, v)


_HAT = {REVOLUTE: np.array([[0.0, -1, 0, 0], [1, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 0]]),
        PRISMATIC: np.array([[0.0, 0, 0, 0], [0, 0, 0, 0], [0, 0, 0, 1], [0, 0, 0, 0]])}


def _merge(run):
    """Frames `run` (top down, z-aligned, driven by one source column q) as one:
    C(q) = M_1(v_1) pre_2 M_2(v_2) ... = S(q) C(0) with S one screw, v_i = g_i q + o_i. Returns (the
    merged frame, the constant C(0) after its motion, turned back from the new frame), or None
    where C is not one screw."""
    def parts(q):  # the factors of C(q)
        out = []
        for i, f in enumerate(run):
            if i:
                out.append(f["pre"])
            out.append(_motion(f["kind"], f["gain"] * q + f["offset"]))
        return out

    def product(ms):
        T = np.eye(4)
        for m in ms:
            T = T @ m
        return T

    factors = parts(0.0)
    K = product(factors)
    dC = np.zeros((4, 4))
    for i, f in enumerate(run):  # d/dq of M_i(v_i) = g_i M_i Hat
        k = 2 * i  # M_i's place among the factors
        dC += f["gain"] * product(factors[: k + 1]) @ _HAT[f["kind"]] @ product(factors[k + 1:])
    xi = dC @ np.linalg.inv(K)
    w, v = np.array([xi[2, 1], xi[0, 2], xi[1, 0]]), xi[:3, 3]
    rate = float(np.linalg.norm(w))
    if rate > 1e-9:
        axis, kind = w / rate, REVOLUTE
        if abs(axis @ v) > 1e-9 * max(1.0, float(np.linalg.norm(v))):
            return None  # a helical motion: no joint of ours
        point = np.cross(w, v) / rate ** 2
    else:
        rate = float(np.linalg.norm(v))
        if rate < 1e-12:
            return None
        axis, kind, point = v / rate, PRISMATIC, np.zeros(3)
    for q in (-2.0, -0.7, 0.3, 1.1, 2.5):  # within 0.1 nm (the URDF's numbers have 12 digits)
        if np.abs(screw_motion(axis, point, kind, rate * q) @ K - product(parts(q))).max() > MERGE_TOLERANCE:
            return None
    shift = np.eye(4)
    shift[:3, 3] = point
    R = _z_to(axis)
    frame = dict(pre=run[0]["pre"] @ shift @ R, kind=kind, column=run[0]["column"], gain=rate, offset=0.0)
    return frame, R.T @ np.linalg.inv(shift) @ K


def load_urdf(path: str | os.PathLike) -> yourdfpy.URDF:
    """A URDF without meshes (kinematics and primitives only)."""
    return yourdfpy.URDF.load(str(Path(path)), build_scene_graph=False, load_meshes=False)


__all__ = ["Chain", "FIXED", "PRISMATIC", "REVOLUTE", "load_urdf", "rotation_xyzw"]
