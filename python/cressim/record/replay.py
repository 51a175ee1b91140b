"""Replay: drive the twin from a recorded bag and measure how well it tracks.

The sim-to-real controller-testing loop::

    commands = load_commands("bags/real_run")              # servo_jp, move_jp, jaw/..., state_command
    result = replay(commands, link.publish, link)          # original timing; link: ROS or LoopbackTwin
    table = tracking_error(result.reference(), result.measured)   # per joint: rms, mean, max, final
    gap = tracking_error(recorded_response("bags/real_run", commands), result.measured, hold="linear")

Everything here is plain Python: ``publish(topic, msgtype, cdr_bytes)`` is a callback and the
measured state comes from any object with ``drain() -> [(topic, t_clock, joint_state)]``
(topic relative to the namespace: "measured_js", "jaw/measured_js"; t_clock on the replay's
``clock``). cressim.record.ros supplies both over rclpy; LoopbackTwin supplies both in-process.

Times: the replay timeline is bag time in seconds since the first command. A command recorded
at t is published at T0 + t / rate; a measured sample received at clock time c is placed at
(c - T0) * rate. Errors are measured minus reference, per joint, over samples at or after the
first reference of their joint group.
"""
from __future__ import annotations

import time
from typing import Any, Callable, Iterable, NamedTuple, Sequence

import numpy as np

from . import types as _types
from .reader import read_messages
from .schema import (ARM_JOINTS, DEFAULT_NAMESPACE, JAW_JOINTS, JOINT_UNITS, MEASURED_FOR, POSITION_COMMANDS,
                     SETPOINT_AS_COMMAND, TOPICS_BY_NAME, canonical_joint, relative_name)
from .synthetic import HOME, LagModel

GROUPS = (ARM_JOINTS, JAW_JOINTS)
MEASURED_TOPICS = {v: k for k, v in MEASURED_FOR.items()}  # "measured_js" -> ARM_JOINTS


class Command(NamedTuple):
    t: float  # s since the first command, bag timeline
    topic: str  # relative to the namespace, as it will be published
    msgtype: str
    data: bytes  # CDR as recorded
    joints: tuple | None  # joint group of an absolute position command, else None
    position: np.ndarray | None  # its positions in `joints` order
    log_time: int  # ns, as recorded


class JointSample(NamedTuple):
    t: float  # s on the replay timeline
    joints: tuple
    position: np.ndarray  # in `joints` order; NaN where the message lacked a joint


class ReplayResult(NamedTuple):
    commands: list  # (t_sent on the replay timeline, Command)
    measured: dict  # joint group (tuple) -> list[JointSample]
    max_lateness: float  # s: worst delay of a publish behind its schedule
    wall_s: float

    def reference(self) -> dict:
        """{group: list[JointSample]} of the position commands, at their scheduled times."""
        return command_reference(c for _, c in self.commands)


def joint_positions(msg: Any, group: Sequence[str]) -> np.ndarray:
    """Positions of a JointState (dataclass, rclpy message or dict) in group order.

    Without names the values are taken in group order; with names, dVRK 2.2 names are accepted
    and missing joints are NaN."""
    get = msg.get if isinstance(msg, dict) else lambda k: getattr(msg, k)
    names = list(get("name") or [])
    pos = np.asarray(get("position"), dtype=float).reshape(-1)
    out = np.full(len(group), np.nan)
    if not names:
        n = min(len(group), len(pos))
        out[:n] = pos[:n]
        return out
    index = {j: i for i, j in enumerate(group)}
    for name, value in zip(names, pos):
        try:
            i = index.get(canonical_joint(name))
        except ValueError:
            continue
        if i is not None:
            out[i] = value
    return out


def load_commands(bag, *, ns: str = DEFAULT_NAMESPACE, topics: Iterable[str] | None = None,
                  from_setpoint: bool | None = None, state_commands: bool = True) -> list[Command]:
    """The commands to replay from a bag, in time order.

    topics: relative command topics to use (default: every command topic of the schema found
    in the bag). from_setpoint: replay the recorded setpoint_js / jaw/setpoint_js as servo_jp /
    jaw/servo_jp (a real robot's setpoints); None (default) does so only when the bag has no
    position commands. state_commands: include state_command (enable, home, ...)."""
    wanted = set(topics) if topics is not None else {n for n, t in TOPICS_BY_NAME.items() if t.role == "command"}
    if not state_commands:
        wanted.discard("state_command")
    raw = []
    for m in read_messages(bag):
        rel = relative_name(m.topic, ns)
        if rel in wanted or rel in SETPOINT_AS_COMMAND:
            raw.append((rel, m))
    has_position = any(rel in POSITION_COMMANDS for rel, _ in raw)
    if from_setpoint is None:
        from_setpoint = not has_position
    chosen = []
    for rel, m in raw:
        if rel in SETPOINT_AS_COMMAND:
            if not from_setpoint:
                continue
            rel = SETPOINT_AS_COMMAND[rel]
        elif from_setpoint and rel in POSITION_COMMANDS:
            continue  # the setpoints replace the recorded position commands
        chosen.append((rel, m))
    if not chosen:
        return []
    t0 = min(m.log_time for _, m in chosen)
    commands = []
    for rel, m in chosen:
        group = POSITION_COMMANDS.get(rel)
        position = joint_positions(m.decode(), group) if group else None
        commands.append(Command((m.log_time - t0) / 1e9, rel, m.msgtype, m.data, group, position, m.log_time))
    commands.sort(key=lambda c: c.t)
    return commands


def prepend_enable(commands: Sequence[Command], delay: float = 2.0) -> list[Command]:
    """`enable` and `home` state commands at t=0 and 0.01 s, the given commands `delay` s later
    (for a twin that starts DISABLED and a bag that does not enable it)."""
    msgtype = "crtk_msgs/msg/StringStamped"
    # log times as if recorded `delay` before the first command: recorded_response stays aligned
    t0 = (min(c.log_time - int(round(c.t * 1e9)) for c in commands) if commands else 0) - int(round(delay * 1e9))
    first = [Command(0.0, "state_command", msgtype, _types.encode({"string": "enable"}, msgtype)[1], None, None, t0),
             Command(0.01, "state_command", msgtype, _types.encode({"string": "home"}, msgtype)[1], None, None,
                     t0 + 10_000_000)]
    return first + [c._replace(t=c.t + delay) for c in commands]


def command_reference(commands: Iterable[Command]) -> dict:
    """{joint group: [JointSample]} of the absolute position commands."""
    out: dict = {g: [] for g in GROUPS}
    for c in commands:
        if c.joints is not None and c.position is not None:
            out[c.joints].append(JointSample(c.t, c.joints, c.position))
    return {g: v for g, v in out.items() if v}


def recorded_response(bag, commands: Sequence[Command], *, ns: str = DEFAULT_NAMESPACE) -> dict:
    """{group: [JointSample]} of the bag's own measured_js / jaw/measured_js (e.g. the real arm's),
    on the replay timeline of `commands` (for the sim-vs-real comparison)."""
    if not commands:
        return {}
    t0 = min(c.log_time for c in commands)
    out: dict = {}
    topics = [f"/{ns.strip('/')}/{t}" for t in MEASURED_TOPICS]
    for m, msg in read_messages(bag, topics, decode=True):
        group = MEASURED_TOPICS[relative_name(m.topic, ns)]
        out.setdefault(group, []).append(JointSample((m.log_time - t0) / 1e9, group, joint_positions(msg, group)))
    return out


def tracking_error(reference: dict, measured: dict, *, hold: str = "zoh", t_min: float | None = None,
                   t_max: float | None = None) -> dict:
    """Per joint error statistics of measured samples against a reference.

    reference, measured: {joint group: [JointSample]}. hold: "zoh" (the latest reference at or
    before each measured sample: what a servo loop is asked to track) or "linear"
    (interpolation: comparing two sampled responses). Only measured samples within the
    reference's time span (zoh: from its first sample on) and [t_min, t_max] count.
    Returns {joint: {"rms", "mean", "mean_abs", "max_abs", "final", "n", "unit"}}; error =
    measured - reference (rad, m for insertion)."""
    if hold not in ("zoh", "linear"):
        raise ValueError("hold must be 'zoh' or 'linear'")
    result = {}
    for group in GROUPS:
        ref, meas = reference.get(group), measured.get(group)
        if not ref or not meas:
            continue
        tr = np.array([s.t for s in ref])
        qr = np.stack([s.position for s in ref])
        order = np.argsort(tr, kind="stable")
        tr, qr = tr[order], qr[order]
        tm = np.array([s.t for s in meas])
        qm = np.stack([s.position for s in meas])
        keep = tm >= tr[0]
        if hold == "linear":
            keep &= tm <= tr[-1]
        if t_min is not None:
            keep &= tm >= t_min
        if t_max is not None:
            keep &= tm <= t_max
        tm, qm = tm[keep], qm[keep]
        for j, joint in enumerate(group):
            valid_r = ~np.isnan(qr[:, j])
            if not valid_r.any() or len(tm) == 0:
                continue
            trj, qrj = tr[valid_r], qr[valid_r, j]
            if hold == "zoh":
                idx = np.searchsorted(trj, tm, side="right") - 1
                ok = idx >= 0
                rj = np.where(ok, qrj[np.clip(idx, 0, None)], np.nan)
            else:
                rj = np.interp(tm, trj, qrj)
            err = qm[:, j] - rj
            err = err[~np.isnan(err)]
            if len(err) == 0:
                continue
            result[joint] = {"rms": float(np.sqrt(np.mean(err ** 2))), "mean": float(np.mean(err)),
                             "mean_abs": float(np.mean(np.abs(err))), "max_abs": float(np.max(np.abs(err))),
                             "final": float(err[-1]), "n": int(len(err)), "unit": JOINT_UNITS[joint]}
    return result


def format_errors(errors: dict, title: str = "tracking error (measured - reference)") -> str:
    """A fixed-width table of tracking_error's result (rad; m for insertion)."""
    lines = [title, f"  {'joint':12s} {'unit':4s} {'rms':>11s} {'mean':>11s} {'max |e|':>11s} {'final':>11s} {'n':>6s}"]
    for joint in ARM_JOINTS + JAW_JOINTS:
        e = errors.get(joint)
        if e is None:
            continue
        lines.append(f"  {joint:12s} {e['unit']:4s} {e['rms']:11.3e} {e['mean']:11.3e} {e['max_abs']:11.3e} "
                     f"{e['final']:11.3e} {e['n']:6d}")
    if len(lines) == 2:
        lines.append("  (no overlapping reference and measured samples)")
    return "\n".join(lines)


def restamp(data: bytes, msgtype: str, now_ns: int) -> bytes:
    """The message with header.stamp set to now_ns (stamps must be the receiver's 'now', never 0)."""
    store = _types.typestore()
    if msgtype not in store.types or "header" not in store.types[msgtype].__dataclass_fields__:
        return data
    msg = store.deserialize_cdr(data, msgtype)
    stamp_cls = store.types["builtin_interfaces/msg/Time"]
    msg.header.stamp = stamp_cls(sec=now_ns // 1_000_000_000, nanosec=now_ns % 1_000_000_000)
    return bytes(store.serialize_cdr(msg, msgtype))


def _to_samples(items, t0: float, rate: float, into: dict) -> None:
    for topic, t_clock, msg in items:
        group = MEASURED_TOPICS.get(topic)
        if group is None:
            continue
        into.setdefault(group, []).append(JointSample((t_clock - t0) * rate, group, joint_positions(msg, group)))


def replay(commands: Sequence[Command], publish: Callable[[str, str, bytes], Any], measured=None, *,
           rate: float = 1.0, settle: float = 0.5, clock: Callable[[], float] = time.monotonic,
           sleep: Callable[[float], Any] = time.sleep, stamp_clock: Callable[[], int] = time.time_ns,
           restamp_headers: bool = True, poll: float = 0.01) -> ReplayResult:
    """Publish commands with their recorded timing (scaled by 1/rate) and collect the response.

    publish(topic, msgtype, cdr) is called for each command (header stamps set to stamp_clock()
    unless restamp_headers=False); measured.drain() is polled while waiting, and for `settle`
    seconds (replay timeline) after the last command."""
    if rate <= 0:
        raise ValueError("rate must be positive")
    samples: dict = {}
    sent = []
    lateness = 0.0
    start = clock()

    def drain():
        if measured is not None:
            _to_samples(measured.drain(), start, rate, samples)

    for c in commands:
        due = start + c.t / rate
        while True:
            now = clock()
            if now >= due:
                break
            drain()
            sleep(min(poll, due - now))
        data = restamp(c.data, c.msgtype, stamp_clock()) if restamp_headers else c.data
        publish(c.topic, c.msgtype, data)
        now = clock()
        lateness = max(lateness, now - due)
        sent.append(((now - start) * rate, c))
    end = clock() + settle / rate
    while clock() < end:
        drain()
        sleep(min(poll, max(0.0, end - clock())))
    drain()
    for group in samples:
        samples[group].sort(key=lambda s: s.t)
    return ReplayResult(sent, samples, lateness, clock() - start)


class SimulatedClock:
    """Time that passes only when slept: a loopback replay on it runs as fast as the machine
    allows and gives the same result on any machine, loaded or not (a wall clock let a busy
    machine's late wake-ups reach the stand-in twin's 100 Hz model as command timing)."""

    def __init__(self, t0: float = 0.0):
        self.t = t0

    def __call__(self) -> float:
        return self.t

    def sleep(self, seconds: float) -> None:
        self.t += max(0.0, seconds)


class LoopbackTwin:
    """An in-process stand-in for the twin: publish() feeds position commands to a LagModel per
    joint group, drain() returns the measured_js / jaw/measured_js it produced at 100 Hz up to
    now. For running and testing replay without ROS (``cressim replay --loopback``)."""

    def __init__(self, *, tau: float = 0.03, period: float = 0.01, clock: Callable[[], float] = time.monotonic,
                 recorder=None, ns: str = DEFAULT_NAMESPACE, stamp_clock: Callable[[], int] = time.time_ns):
        self.clock, self.period, self.recorder, self.ns, self.stamp_clock = clock, period, recorder, ns, stamp_clock
        self.models = {ARM_JOINTS: LagModel(HOME, tau=tau, period=period),
                       JAW_JOINTS: LagModel([0.0], tau=tau, period=period)}
        self._next = clock()
        self._pending: list = []
        self.received = 0

    def publish(self, topic: str, msgtype: str, data: bytes) -> None:
        self.received += 1
        self._advance()
        group = POSITION_COMMANDS.get(topic)
        if group is None:
            return
        q = joint_positions(_types.decode(data, msgtype), group)
        model = self.models[group]
        model.command(np.where(np.isnan(q), model.target, q))

    def _advance(self) -> list:
        out = []
        now = self.clock()
        while self._next <= now:
            for group, model in self.models.items():
                q = model.step()
                topic = MEASURED_FOR[group]
                msg = {"header": {"stamp": _types.stamp(self.stamp_clock())}, "name": list(group),
                       "position": q.tolist(), "velocity": model.qd.tolist()}
                out.append((topic, self._next, msg))
                if self.recorder is not None:
                    self.recorder.write(f"/{self.ns.strip('/')}/{topic}", msg, msgtype="sensor_msgs/msg/JointState")
            self._next += self.period
        self._pending.extend(out)
        return out

    def drain(self) -> list:
        self._advance()
        out, self._pending = self._pending, []
        return out


__all__ = ["Command", "JointSample", "LoopbackTwin", "ReplayResult", "SimulatedClock", "command_reference", "format_errors",
           "joint_positions", "load_commands", "prepend_enable", "recorded_response", "replay", "restamp",
           "tracking_error"]
