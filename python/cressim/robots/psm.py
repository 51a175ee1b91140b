"""The dVRK PSM: URDF loading, batched FK, Jacobians and closed-form IK on any torch device.

    psm = PSM("psm_lnd.urdf", device="cuda")
    T = psm.forward_kinematics(q)             # (N, 6) -> (N, 4, 4), tool tip in PSM1_base
    J = psm.jacobian(q)                       # (N, 6, 6), [v; w] of the tip in PSM1_base
    q, ok = psm.inverse_kinematics(T, seed=q)  # closed form; ok[i] False: pose i unreachable

FK and Jacobians are the URDF's (cressim.robots.chain), so the links the engine shows and the
poses the twin reports come from one model. The IK is closed form on the frames of the URDF's
insertion and wrist_yaw links, which are the dVRK's DH frames 3 and 6 (tests/robots check the
URDF against the DH table); the tool's lengths it needs are read off the chain at q = 0.
"""
from __future__ import annotations

import math
import os

import numpy as np
from pathlib import Path
from typing import Mapping, NamedTuple, Sequence

import torch

from .chain import Chain, load_urdf
from .dvrk import JAW, PSM_JOINTS, canonical_joint_name

BASE_LINK = "PSM1_base"  # the remote centre of motion, DH frame 0
TIP_LINK = "PSM1_tool_tip_link"  # DH frame 6 times the tool-tip offset
JAW_LINK = "PSM1_wrist_yaw_link"  # the jaws' pivot, DH frame 6; its +y runs along the 10 mm jaws
SHAFT_LINK = "PSM1_insertion_link"  # DH frame 3: its z runs along the shaft, through the RCM
WRIST_LINK = "PSM1_wrist_pitch_link"  # DH frame 5: its origin is the wrist point (on the shaft)
JAW_GRASP_POINT = (0.0, 0.006, 0.0)  # m, in JAW_LINK: between the jaws, where they hold what they grasp
ROBOT_DIR_ENV = "CRESSIM_ROBOT_DIR"  # overrides where robots/dvrk_psm is



def robot_dir() -> Path:
    """robots/dvrk_psm of the CRESSim checkout.

    Searched for upward from this file (a source tree or an editable install) and then from
    the working directory; $CRESSIM_ROBOT_DIR wins when set (a wheel installed elsewhere).
    """
    if os.environ.get(ROBOT_DIR_ENV):
        return Path(os.environ[ROBOT_DIR_ENV])
    for start in (Path(__file__).resolve(), Path.cwd().resolve()):
        for folder in (start, *start.parents):
            candidate = folder / "robots" / "dvrk_psm"
            if (candidate / "psm_lnd.urdf").is_file():
                return candidate
    raise FileNotFoundError(
        f"robots/dvrk_psm not found above {Path(__file__).parent} or {Path.cwd()}; set ${ROBOT_DIR_ENV}"
    )


class IKResult(NamedTuple):
    q: torch.Tensor  # (N, dof), always within the joint limits
    reachable: torch.Tensor  # (N,) bool; False: q is only the nearest in-limit guess


class PSM:
    """One PSM model (arm + instrument URDF) for batched kinematics on one torch device."""

    def __init__(self, urdf: str | os.PathLike = "psm_lnd.urdf", *, device="cpu", dtype=torch.float32):
        path = Path(urdf)
        if not path.is_file():
            path = robot_dir() / urdf
        self.urdf_path = path
        self.urdf = load_urdf(path)
        self.device, self.dtype = torch.device(device), dtype

        joints = {j.name: j for j in self.urdf.robot.joints}
        actuated = set(self.urdf.actuated_joint_names)
        # the arm joints this instrument has, in dVRK order (a wrist-less tool has 4)
        self.joint_names = tuple(n for n in PSM_JOINTS if n in actuated)
        self.dof = len(self.joint_names)
        if self.joint_names != PSM_JOINTS[: self.dof] or self.dof < 4:
            raise ValueError(f"{path}: arm joints {self.joint_names} are not a prefix of {PSM_JOINTS}")
        limit = [joints[n].limit for n in self.joint_names]
        self.lower = torch.tensor([lim.lower for lim in limit], device=self.device, dtype=dtype)
        self.upper = torch.tensor([lim.upper for lim in limit], device=self.device, dtype=dtype)
        self.effort = torch.tensor([lim.effort for lim in limit], device=self.device, dtype=dtype)
        self.has_jaw = JAW in actuated
        self.jaw_limits = (joints[JAW].limit.lower, joints[JAW].limit.upper) if self.has_jaw else None

        # the links from the base to the tool tip (the jaw blades, off that way, need no jaw value)
        # the DH frames' links the IK reads, and the tip (the parallelogram's bars not asked for, its
        # three mimic joints compile to one hinge about the RCM)
        self.chain = Chain(self.urdf, sources=self.joint_names, base=BASE_LINK, tip=TIP_LINK,
                           links=[n for n in (SHAFT_LINK, WRIST_LINK, JAW_LINK, TIP_LINK) if n in self.urdf.link_map])
        self._shaft = _shaft_facts(self.chain, self.dof)

    def __repr__(self):
        return f"PSM({self.urdf_path.name!r}, dof={self.dof}, device={self.device})"

    # ------------------------------------------------------------------ joint vectors
    def joint_vector(self, values, names: Sequence[str] | None = None) -> torch.Tensor:
        """Joint values in this model's order, as a tensor on its device.

        values: a mapping name -> value(s), or an array (..., len(names)) with `names`, or an
        array (..., dof) already in order. Old (outer_*) and new names are both accepted.
        """
        if isinstance(values, Mapping):
            names, values = list(values.keys()), [torch.as_tensor(v, dtype=self.dtype) for v in values.values()]
            values = torch.stack(torch.broadcast_tensors(*values), dim=-1)
        q = torch.as_tensor(values, dtype=self.dtype).to(self.device)
        if names is None:
            return self._check_width(q)
        order = [canonical_joint_name(n) for n in names]
        if q.shape[-1] != len(order) or len(set(order)) != len(order):
            raise ValueError(f"{q.shape[-1]} values for joints {list(names)}")
        missing = [n for n in self.joint_names if n not in order]
        extra = [n for n in order if n not in self.joint_names]
        if missing or extra:
            raise ValueError(f"joints missing {missing}, not in this instrument {extra}")
        return q[..., [order.index(n) for n in self.joint_names]]

    def within_limits(self, q: torch.Tensor, tol: float = 0.0) -> torch.Tensor:
        """(..., dof) -> (...) bool: every joint within [lower - tol, upper + tol]."""
        q = self._check_width(torch.as_tensor(q, device=self.device))
        return ((q >= self.lower - tol) & (q <= self.upper + tol)).all(dim=-1)

    def clamp(self, q: torch.Tensor) -> torch.Tensor:
        """Clamp (..., dof) joint values to the limits."""
        q = self._check_width(torch.as_tensor(q, device=self.device))
        return torch.maximum(torch.minimum(q, self.upper.to(q.dtype)), self.lower.to(q.dtype))

    def _check_width(self, q):
        if q.shape[-1] != self.dof:
            raise ValueError(f"expected (..., {self.dof}) joint values {self.joint_names}, got {tuple(q.shape)}")
        return q

    def _q(self, q):
        return self._check_width(torch.as_tensor(q, device=self.device, dtype=self.dtype))

    # ------------------------------------------------------------------ kinematics
    def forward_kinematics(self, q) -> torch.Tensor:
        """Tool-tip pose in PSM1_base: (..., dof) -> (..., 4, 4)."""
        return self.chain.forward(self._q(q))

    def link_pose(self, link: str, q) -> torch.Tensor:
        """Pose in PSM1_base of the insertion, wrist pitch, wrist yaw (JAW_LINK) or tip link:
        (..., dof) -> (..., 4, 4)."""
        return self.chain.link_pose(link, self._q(q))

    def jacobian(self, q, *, return_pose: bool = False):
        """Geometric Jacobian of the tool tip in PSM1_base: (..., dof) -> (..., 6, dof).

        Rows are [linear velocity of the tip point; angular velocity], both in PSM1_base
        (the dVRK's spatial Jacobian uses the same base frame). With return_pose also the tip pose.
        """
        J, T = self.chain.jacobian(self._q(q))
        return (J, T) if return_pose else J

    def inverse_kinematics(self, pose, *, seed=None, strict: bool = False,
                           position_tol: float = 1e-5, rotation_tol: float = 1e-4) -> IKResult:
        """Joint values that put the tool tip at `pose` (..., 4, 4) in PSM1_base.

        Closed form: the RCM and the wrist point fix yaw, pitch and insertion; the remaining
        rotation fixes roll, wrist pitch and wrist yaw. Each branch is clamped to the joint
        limits and kept if its FK still matches the pose (tolerances in m and rad); among those
        the one nearest `seed` wins (nearest zero without one), which also picks the roll turn
        (its range spans more than one). reachable[i] is False where no branch is left; q[i]
        is then the in-limit branch nearest the pose, and strict=True raises ValueError
        instead. A 4-DOF (wrist-less) tool reaches a pose only if the straight tool can take
        its orientation. Near the RCM singularity (insertion ~0.0156 m: the wrist point in the
        RCM, where yaw, pitch, roll and wrist pitch all turn about one point) float32 noise in
        the pose moves the joints a lot; there a pose at a joint limit may be flagged.
        """
        T = torch.as_tensor(pose, device=self.device).to(torch.float64)
        lead = T.shape[:-2]
        T = T.reshape(-1, 4, 4)
        if seed is None:  # prefer the solution nearest the zero configuration (deterministic)
            reference = torch.zeros(T.shape[0], self.dof, device=self.device, dtype=torch.float64)
        else:
            reference = self._check_width(torch.as_tensor(seed, device=self.device)).to(torch.float64)
            reference = reference.reshape(-1, self.dof).expand(T.shape[0], self.dof)
        lower, upper = self.lower.double(), self.upper.double()
        tip_rot = torch.as_tensor(self._shaft["tip_rotation"], device=self.device, dtype=torch.float64)
        R6 = T[:, :3, :3] @ tip_rot.T  # DH frame 6 (4 without a wrist); the tip offset is a pure rotation

        best_q = best_cost = None
        for q in self._ik_candidates(R6, T[:, :3, 3]):
            q4 = q[:, 3] + 2 * math.pi * torch.round((reference[:, 3] - q[:, 3]) / (2 * math.pi))
            q4 = torch.where(q4 > upper[3], q4 - 2 * math.pi, q4)  # roll turn nearest the
            q4 = torch.where(q4 < lower[3], q4 + 2 * math.pi, q4)  # reference, within limits
            q = torch.cat([q[:, :3], q4[:, None], q[:, 4:]], dim=-1)
            q = torch.nan_to_num(torch.maximum(torch.minimum(q, upper), lower))
            err_p, err_r = _pose_error(self.chain.forward(q), T)
            exact = (err_p < position_tol) & (err_r < rotation_tol)
            # exact ones first, nearest the reference among them; others by their error
            cost = torch.where(exact, (q - reference).abs().sum(-1), 1e3 + err_p + err_r)
            cost = torch.nan_to_num(cost, nan=1e9)
            better = cost < best_cost if best_cost is not None else torch.ones_like(exact)
            best_q = q if best_q is None else torch.where(better[:, None], q, best_q)
            best_cost = cost if best_cost is None else torch.where(better, cost, best_cost)
        reachable = best_cost < 1e3
        if strict and not bool(reachable.all()):
            bad = torch.nonzero(~reachable).flatten().tolist()
            raise ValueError(f"unreachable poses (within joint limits) at batch indices {bad}")
        return IKResult(best_q.to(self.dtype).reshape(*lead, self.dof), reachable.reshape(lead))

    def _ik_candidates(self, R6, p):
        """Every closed-form branch as a (N, dof) float64 tensor (some may be invalid)."""
        if self.dof == 6:
            # The wrist pitch axis z5 is normal to the wrist yaw axis z6 (= y5) and to the shaft,
            # which passes through the RCM (the origin) and the wrist point p5 = p - a6 x5 with
            # x5 normal to z5: so z5 is normal to z6 and p. Its sign picks the wrist branch.
            z6 = R6[:, :, 2]
            n = torch.linalg.cross(z6, p)
            n = n / n.norm(dim=-1, keepdim=True).clamp_min(1e-12)
            along, wrist = self._shaft["wrist_along"], self._shaft["wrist"]  # RCM to wrist point: q3 - along
            shafts = []
            for sign in (1.0, -1.0):
                p5 = p - wrist * torch.linalg.cross(z6, sign * n)
                r = p5.norm(dim=-1, keepdim=True)
                # the wrist point beyond the RCM (usual), or still behind it (q3 < along)
                shafts += [(p5 / r.clamp_min(1e-12), along + r[:, 0]), (-p5 / r.clamp_min(1e-12), along - r[:, 0])]
        else:
            # straight tool: the shaft runs along z4, and the tip lies on it (q3 - along) beyond the
            # RCM; position-free, so exact even near the RCM
            z3 = R6[:, :, 2]
            along = self._shaft["tip_along"]
            shafts = [(z3, along + (p * z3).sum(-1))]
        for z3, q3 in shafts:
            # in DH frames, z3 = (sin q1 cos q2, -sin q2, -cos q1 cos q2)
            q2 = torch.atan2(-z3[:, 1], torch.hypot(z3[:, 0], z3[:, 2]))
            q1 = torch.atan2(z3[:, 0], -z3[:, 2])
            q123 = torch.stack([q1, q2, q3, *[torch.zeros_like(q1)] * (self.dof - 3)], dim=-1)
            R3 = self.chain.link_pose(SHAFT_LINK, q123)[:, :3, :3]
            M = R3.transpose(-1, -2) @ R6  # rotation from frame 3 to frame 6
            if self.dof == 6:
                # in DH frames, M's third column is (cos q4 cos q5, sin q4 cos q5, -sin q5)
                # and its third row starts (sin q6 cos q5, cos q6 cos q5); |q5| < pi/2 in limits
                q4 = torch.atan2(M[:, 1, 2], M[:, 0, 2])
                q5 = torch.atan2(-M[:, 2, 2], torch.hypot(M[:, 0, 2], M[:, 1, 2]))
                q6 = torch.atan2(M[:, 2, 0], M[:, 2, 1])
                rest = [q5, q6]
            else:
                q4 = torch.atan2(M[:, 1, 0], M[:, 0, 0])  # M = Rz(q4)
                rest = []
            yield torch.stack([q1, q2, q3, q4, *rest], dim=-1)


def _shaft_facts(chain: Chain, dof: int) -> dict:
    """The tool's lengths along its shaft at q = 0, from the chain (float64): where the wrist point
    (the wrist pitch axis on the shaft; the tip for a wrist-less tool) sits along the shaft from
    the RCM at insertion 0 (negative: behind it), the wrist pitch axis to the jaw pivot, and the
    tip's rotation from DH frame 6 (the jaw pivot link)."""
    zero = torch.zeros(1, dof, dtype=torch.float64)
    poses = {n: chain.link_pose(n, zero)[0].numpy() for n in chain.links}
    z3 = poses[SHAFT_LINK][:3, 2]
    facts = {"tip_along": -float(poses[TIP_LINK][:3, 3] @ z3)}
    if dof == 6:
        facts["wrist_along"] = -float(poses[WRIST_LINK][:3, 3] @ z3)
        facts["wrist"] = float(np.linalg.norm(poses[JAW_LINK][:3, 3] - poses[WRIST_LINK][:3, 3]))
        facts["tip_rotation"] = poses[JAW_LINK][:3, :3].T @ poses[TIP_LINK][:3, :3]
    else:  # a straight tool: from DH frame 4 (frame 3 turned by the roll) to the tip
        facts["tip_rotation"] = poses[SHAFT_LINK][:3, :3].T @ poses[TIP_LINK][:3, :3]
    return facts


def _pose_error(A, B):
    """Position error (m) and rotation angle error (rad) between batches of 4x4 poses."""
    err_p = (A[..., :3, 3] - B[..., :3, 3]).norm(dim=-1)
    R = A[..., :3, :3].transpose(-1, -2) @ B[..., :3, :3]
    # atan2 of sin and cos of the angle: precise near 0, unlike acos of the trace alone
    sin = torch.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], -1)
    cos = (R.diagonal(dim1=-2, dim2=-1).sum(-1) - 1) / 2
    return err_p, torch.atan2(sin.norm(dim=-1) / 2, cos)


__all__ = ["BASE_LINK", "IKResult", "JAW_GRASP_POINT", "JAW_LINK", "PSM", "SHAFT_LINK", "TIP_LINK", "WRIST_LINK",
           "canonical_joint_name", "robot_dir"]
