"""A synthetic PSM session, for the sample bag, tests and replay without a twin.

``LagModel`` is a stand-in for the arm: each joint follows its latest position command with a
first-order lag (time constant tau) sampled at 100 Hz. ``synthetic_session`` drives it with a
smooth servo_jp trajectory inside the joint limits and returns what a recorder on the real
arm would have seen: state commands, servo commands, setpoint/measured joint states, tool-tip
poses and tf, on the schema's topics, in time order.

The poses are the real arm's own kinematics, the dVRK's DH table (cressim.robots.dvrk_dh), on
purpose not the twin's URDF chain: a recording of the "real" arm by a model independent of ours,
and numpy only (bit for bit the same on every machine: the committed sample bag is compared with
a fresh one).
"""
from __future__ import annotations

import math
from typing import Iterator, NamedTuple

import numpy as np

from ..robots.dvrk_dh import dh_forward_kinematics
from .schema import ARM_JOINTS, JAW_JOINTS
from .types import stamp

HOME = np.array([0.0, 0.0, 0.12, 0.0, 0.0, 0.0])  # insertion part-way in, as a homed tool sits
JOINT_STATE = "sensor_msgs/msg/JointState"


class LagModel:
    """Joints that follow position commands with a first-order lag, stepped at a fixed period."""

    def __init__(self, q0, *, tau: float = 0.03, period: float = 0.01, noise: float = 0.0, seed: int = 0):
        self.q = np.array(q0, dtype=float)
        self.target = self.q.copy()
        self.qd = np.zeros_like(self.q)
        self.tau, self.period, self.noise = tau, period, noise
        self._alpha = 1.0 - math.exp(-period / tau)
        self._rng = np.random.default_rng(seed)

    def command(self, q) -> None:
        self.target = np.array(q, dtype=float)

    def step(self) -> np.ndarray:
        """Advance one period; returns the measured position (with noise, if any)."""
        prev = self.q.copy()
        self.q = self.q + self._alpha * (self.target - self.q)
        self.qd = (self.q - prev) / self.period
        if self.noise:
            return self.q + self._rng.normal(0.0, self.noise, self.q.shape)
        return self.q.copy()


def servo_trajectory(t: float) -> tuple[np.ndarray, np.ndarray]:
    """(arm q, jaw q) of a smooth test motion at time t (s); sines well inside the limits."""
    s = math.sin
    arm = HOME + np.array([0.35 * s(0.9 * t), 0.25 * s(1.3 * t + 0.5), 0.03 * s(0.7 * t),
                           0.8 * s(0.5 * t), 0.4 * s(1.7 * t), 0.4 * s(1.1 * t + 1.0)])
    jaw = np.array([0.35 + 0.3 * s(2.0 * t)])
    return arm, jaw


def joint_state(t_ns: int, names, position, velocity=(), effort=()) -> dict:
    return {"header": {"stamp": stamp(t_ns), "frame_id": ""}, "name": list(names),
            "position": list(position), "velocity": list(velocity), "effort": list(effort)}


def _pose(T: np.ndarray) -> dict:
    R = T[:3, :3]
    # rotation matrix -> unit quaternion (x, y, z, w), numerically stable branch
    tr = np.trace(R)
    if tr > 0:
        w = math.sqrt(1.0 + tr) / 2
        x, y, z = (R[2, 1] - R[1, 2]) / (4 * w), (R[0, 2] - R[2, 0]) / (4 * w), (R[1, 0] - R[0, 1]) / (4 * w)
    else:
        i = int(np.argmax(np.diag(R)))
        j, k = (i + 1) % 3, (i + 2) % 3
        r = math.sqrt(1.0 + R[i, i] - R[j, j] - R[k, k])
        q = [0.0, 0.0, 0.0]
        q[i] = r / 2
        q[j] = (R[j, i] + R[i, j]) / (2 * r)
        q[k] = (R[k, i] + R[i, k]) / (2 * r)
        w = (R[k, j] - R[j, k]) / (2 * r)
        x, y, z = q
        if w < 0:
            x, y, z, w = -x, -y, -z, -w
    return {"position": {"x": T[0, 3], "y": T[1, 3], "z": T[2, 3]},
            "orientation": {"x": x, "y": y, "z": z, "w": w}}


def _forward_kinematics(q: np.ndarray) -> np.ndarray:
    """Tool-tip poses (N, 4, 4) in {ns}_base of joint vectors (N, 6): the DH table's."""
    return dh_forward_kinematics(np.atleast_2d(np.asarray(q, dtype=np.float64)))


class Timed(NamedTuple):
    topic: str
    msgtype: str
    log_time: int
    msg: dict


def synthetic_session(*, duration: float = 4.0, start_ns: int = 1_700_000_000_000_000_000, ns: str = "PSM1",
                      rate: float = 100.0, tau: float = 0.03, noise: float = 2e-4, seed: int = 0,
                      poses: bool = True, tf: bool = True) -> Iterator[Timed]:
    """Messages of a synthetic session, in log-time order (see module docstring).

    Timeline: t=0 DISABLED; 0.05 s `enable` -> ENABLED; 0.10 s `home` -> busy, 0.30 s homed;
    from 0.5 s servo_jp / jaw/servo_jp at `rate` until `duration`. setpoint_js is the latest
    command; measured_js is the LagModel response plus Gaussian noise (std `noise`).
    """
    p = f"/{ns.strip('/')}/"
    base = f"{ns.strip('/')}_base"
    period = 1.0 / rate
    arm = LagModel(HOME, tau=tau, period=period, noise=noise, seed=seed)
    jaw = LagModel([0.0], tau=tau, period=period, noise=noise, seed=seed + 1)
    events = [
        (0.0, "operating_state", "crtk_msgs/msg/OperatingState", ("DISABLED", False, False)),
        (0.05, "state_command", "crtk_msgs/msg/StringStamped", "enable"),
        (0.06, "operating_state", "crtk_msgs/msg/OperatingState", ("ENABLED", False, False)),
        (0.10, "state_command", "crtk_msgs/msg/StringStamped", "home"),
        (0.11, "operating_state", "crtk_msgs/msg/OperatingState", ("ENABLED", False, True)),
        (0.30, "operating_state", "crtk_msgs/msg/OperatingState", ("ENABLED", True, False)),
    ]
    out: list[Timed] = []

    def at(t: float) -> int:
        return start_ns + int(round(t * 1e9))

    for t, topic, msgtype, value in events:
        tn = at(t)
        if msgtype.endswith("OperatingState"):
            msg = {"header": {"stamp": stamp(tn)}, "state": value[0], "is_homed": value[1], "is_busy": value[2]}
        else:
            msg = {"header": {"stamp": stamp(tn)}, "string": value}
        out.append(Timed(p + topic, msgtype, tn, msg))

    steps = int(round(duration * rate))
    servo_from = int(round(0.5 * rate))
    rows = []  # (k, (arm, jaw) command or None, measured arm, qd, effort, arm target, measured jaw, qd, jaw target)
    for k in range(steps):
        t = k * period
        cmd = None
        if k >= servo_from:
            cmd = servo_trajectory(t - servo_from * period)
            arm.command(cmd[0])
            jaw.command(cmd[1])
        m_arm, m_jaw = arm.step(), jaw.step()
        effort = 0.05 * (arm.target - arm.q) / max(tau, 1e-6)
        rows.append((k, cmd, m_arm, arm.qd.copy(), effort, arm.target.copy(), m_jaw, jaw.qd.copy(), jaw.target.copy()))
    if poses and rows:  # forward kinematics of all samples at once
        fk_measured = _forward_kinematics(np.stack([r[2] for r in rows]))
        fk_setpoint = _forward_kinematics(np.stack([r[5] for r in rows]))
    for i, (k, cmd, m_arm, qd_arm, effort, sp_arm, m_jaw, qd_jaw, sp_jaw) in enumerate(rows):
        tn = at(k * period)
        if cmd is not None:
            out.append(Timed(p + "servo_jp", JOINT_STATE, tn, joint_state(tn, ARM_JOINTS, cmd[0])))
            out.append(Timed(p + "jaw/servo_jp", JOINT_STATE, tn, joint_state(tn, JAW_JOINTS, cmd[1])))
        tm = at((k + 0.5) * period)  # the arm reports half a period after commands arrive
        out.append(Timed(p + "setpoint_js", JOINT_STATE, tm, joint_state(tm, ARM_JOINTS, sp_arm)))
        out.append(Timed(p + "measured_js", JOINT_STATE, tm, joint_state(tm, ARM_JOINTS, m_arm, qd_arm, effort)))
        out.append(Timed(p + "jaw/setpoint_js", JOINT_STATE, tm, joint_state(tm, JAW_JOINTS, sp_jaw)))
        out.append(Timed(p + "jaw/measured_js", JOINT_STATE, tm, joint_state(tm, JAW_JOINTS, m_jaw, qd_jaw)))
        if poses:
            for name, T in (("measured_cp", fk_measured[i]), ("setpoint_cp", fk_setpoint[i])):
                out.append(Timed(p + name, "geometry_msgs/msg/PoseStamped", tm,
                                 {"header": {"stamp": stamp(tm), "frame_id": base}, "pose": _pose(T)}))
            if tf and k % 2 == 0:
                pose = _pose(fk_measured[i])
                transform = {"header": {"stamp": stamp(tm), "frame_id": base}, "child_frame_id": ns.strip("/"),
                             "transform": {"translation": pose["position"], "rotation": pose["orientation"]}}
                out.append(Timed("/tf", "tf2_msgs/msg/TFMessage", tm, {"transforms": [transform]}))
    out.sort(key=lambda m: m.log_time)  # stable: commands before the state they cause
    yield from out


def record_synthetic(bag, *, chunk_size: int | None = None, **kwargs) -> dict:
    """Record synthetic_session(**kwargs) into a new bag (BagWriter, log_time = message time)."""
    from .writer import DEFAULT_CHUNK_SIZE, BagWriter

    writer = BagWriter(bag, on_full="block", chunk_size=chunk_size or DEFAULT_CHUNK_SIZE,
                       custom_data={"source": "cressim.record.synthetic"})
    try:
        for m in synthetic_session(**kwargs):
            writer.write(m.topic, m.msg, msgtype=m.msgtype, log_time=m.log_time)
    finally:
        metadata = writer.close()
    return metadata


__all__ = ["LagModel", "Timed", "record_synthetic", "servo_trajectory", "synthetic_session"]
