"""Validation of incoming commands, before anything touches the twin's state.

Every check returns (value, None) or (None, reason); the reason is the text published on
`error`, so it says what was wrong and what was expected. Nothing here raises on bad input
(the node also wraps callbacks, but a refusal is the normal path, not an exception).

Values are small numpy arrays: a message is one env's command, so this is O(dof) work.
"""
from __future__ import annotations

import math

import numpy as np

from cressim.robots import canonical_joint_name

# A command exactly at a limit (as printed by a client that read it from the URDF, say) is
# fine; this much beyond is refused rather than clamped (a silently moved goal is worse).
LIMIT_TOLERANCE = 1e-5  # the URDF limits are rounded to 6 digits (80 degrees is 1.3962634, the limit 1.39626)
QUATERNION_TOLERANCE = 1e-2  # |q| may differ from 1 by this (rounding in clients); it is renormalised


def joint_values(msg, *, what: str, names: tuple, lower: np.ndarray | None, upper: np.ndarray | None,
                 field: str = "position"):
    """The `field` of a sensor_msgs/JointState in the order of `names`, checked.

    names: the interface's joints (6 arm joints, or ("jaw",)). msg.name may be empty (values in
    that order, as dVRK clients send them) or name every joint once, in any order, with old
    (outer_*) or new names. lower/upper: limits in the order of names (None: no limit check,
    for relative commands, checked by the caller after adding).
    """
    values = list(getattr(msg, field))
    if not values:
        return None, f"{what} refused: JointState.{field} is empty (expected {len(names)} values for {', '.join(names)})"
    if msg.name:
        if len(msg.name) != len(values):
            return None, f"{what} refused: {len(msg.name)} names but {len(values)} {field} values"
        order = []
        for given in msg.name:
            try:
                canon = given if given in names else canonical_joint_name(given)
            except ValueError:
                canon = None
            if canon not in names:
                return None, f"{what} refused: unknown joint name {given!r}; expected {', '.join(names)}"
            if canon in order:
                return None, f"{what} refused: joint {given!r} given twice"
            order.append(canon)
        missing = [n for n in names if n not in order]
        if missing:
            return None, f"{what} refused: joints {', '.join(missing)} missing (all of {', '.join(names)} are needed)"
        values = [values[order.index(n)] for n in names]
    elif len(values) != len(names):
        return None, f"{what} refused: {len(values)} {field} values, expected {len(names)} ({', '.join(names)})"
    q = np.asarray(values, dtype=np.float64)
    bad = np.flatnonzero(~np.isfinite(q))
    if bad.size:
        i = int(bad[0])
        return None, f"{what} refused: {field}[{i}] ({names[i]}) is {q[i]}"
    if lower is not None:
        refusal = limit_refusal(q, names, lower, upper, what=what)
        if refusal:
            return None, refusal
    return q, None


def limit_refusal(q, names, lower, upper, *, what: str) -> str | None:
    """None when q is within [lower, upper] (with LIMIT_TOLERANCE), else which joint is not."""
    out = np.flatnonzero((q < lower - LIMIT_TOLERANCE) | (q > upper + LIMIT_TOLERANCE))
    if not out.size:
        return None
    i = int(out[0])
    note = " (this instrument has no such joint: it must be 0)" if lower[i] == upper[i] == 0.0 else ""
    return (f"{what} refused: {names[i]} = {q[i]:.6g} is beyond its limits "
            f"[{lower[i]:.6g}, {upper[i]:.6g}]{note}")


def pose_matrix(pose, *, what: str):
    """A geometry_msgs/Pose as a 4x4 float64 matrix, checked (finite, unit quaternion)."""
    p, o = pose.position, pose.orientation
    values = np.array([p.x, p.y, p.z, o.x, o.y, o.z, o.w], dtype=np.float64)
    if not np.isfinite(values).all():
        field = ("position.x", "position.y", "position.z", "orientation.x", "orientation.y", "orientation.z",
                 "orientation.w")[int(np.flatnonzero(~np.isfinite(values))[0])]
        return None, f"{what} refused: pose {field} is not finite"
    norm = float(np.linalg.norm(values[3:]))
    if abs(norm - 1.0) > QUATERNION_TOLERANCE:
        return None, f"{what} refused: orientation quaternion has norm {norm:.6g}, not 1"
    x, y, z, w = values[3:] / norm
    T = np.eye(4)
    T[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                 [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                 [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    T[:3, 3] = values[:3]
    return T, None


WALL_CLOCK_WINDOW_NS = 86_400 * 10**9  # a stamp this close to the wall clock is a wall-clock stamp


def stale_refusal(stamp_ns: int, received_ns: int, sim_ns: int, max_age_s: float, *, what: str) -> str | None:
    """A command stamped more than max_age_s before it arrived is refused. Its age is taken at
    arrival (not when the twin gets to it) in the clock it was stamped in: the wall clock, or
    the simulated time for clients on /clock. A zero stamp is 'unstamped'."""
    if max_age_s <= 0 or stamp_ns == 0:
        return None
    if abs(received_ns - stamp_ns) < WALL_CLOCK_WINDOW_NS:
        age = (received_ns - stamp_ns) * 1e-9
    else:
        age = (sim_ns - stamp_ns) * 1e-9
    if age > max_age_s:
        return f"{what} refused: stale command, stamped {age:.3g} s before it arrived (limit {max_age_s:g} s)"
    return None


def ratio_value(value: float, *, what: str):
    if not math.isfinite(value) or not 0.0 < value <= 1.0:
        return None, f"{what} refused: {value} is not in (0, 1]"
    return float(value), None


__all__ = ["LIMIT_TOLERANCE", "joint_values", "limit_refusal", "pose_matrix", "ratio_value", "stale_refusal"]
