"""The twin's /diagnostics: a diagnostic_msgs/DiagnosticArray built from plain numbers (what
TwinNode.statistics() returns), so that the node only counts and this module decides levels.

stats keys (missing ones are left out of the message):
    node            node name; statuses are "<node>: tick", "<node>: <sensor>", "<node>: commands"
    period_ms       tick period (1000 / publish_rate)
    tick_mean_ms, tick_max_ms   tick time over the window
    publish_rate_hz ticks per second measured over the window (measured_js is published per tick)
    target_rate_hz  publish_rate
    num_envs
    sensors         {name: {rate (Hz, simulated time), rendered, skipped, enabled}}, totals
    refusals        {command kind: count}, totals
    console         {console command (power_on, beep, ...): count received}, totals
    hardware_id     optional, default the node name

WARN when the tick overran its period (max or mean), the tick rate fell below RATE_TOLERANCE of
its target, or a sensor skipped frames. Counts are totals; pass the previous call's stats and the
time between the calls to judge skipped frames over that window instead of since start.
"""
from __future__ import annotations

import numbers

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

RATE_TOLERANCE = 0.9  # below 90 % of publish_rate the tick is falling behind


def _kv(key: str, value) -> KeyValue:
    if isinstance(value, bool):
        value = "true" if value else "false"
    elif isinstance(value, numbers.Real) and not isinstance(value, numbers.Integral):  # numpy floats too
        value = f"{value:.2f}"
    return KeyValue(key=key, value=str(value))


def _status(name: str, hardware_id: str, problems: list[str], ok_message: str, values: list) -> DiagnosticStatus:
    return DiagnosticStatus(level=DiagnosticStatus.WARN if problems else DiagnosticStatus.OK, name=name,
                            message="; ".join(problems) if problems else ok_message, hardware_id=hardware_id,
                            values=[_kv(k, v) for k, v in values])


def _tick_status(stats: dict, name: str, hw: str) -> DiagnosticStatus:
    period, mean, worst = stats.get("period_ms"), stats.get("tick_mean_ms"), stats.get("tick_max_ms")
    rate, target = stats.get("publish_rate_hz"), stats.get("target_rate_hz")
    problems = []
    if period and mean is not None and mean > period:
        problems.append(f"tick {mean:.1f} ms on average, over its {period:.1f} ms period")
    elif period and worst is not None and worst > period:
        problems.append(f"tick overran its {period:.1f} ms period (max {worst:.1f} ms)")
    if rate and target and rate < RATE_TOLERANCE * target:  # rate 0: not measured yet
        problems.append(f"measured_js at {rate:.1f} Hz of {target:.0f} Hz")
    parts = [f"tick {k} {v:.1f} ms" for k, v in (("mean", mean), ("max", worst)) if v is not None]
    parts += [f"measured_js {rate:.1f} Hz"] if rate else []
    ok = ", ".join(parts) or "no tick measured yet"
    values = [("tick mean (ms)", mean), ("tick max (ms)", worst), ("period (ms)", period),
              ("measured_js rate (Hz)", rate), ("target rate (Hz)", target), ("envs", stats.get("num_envs"))]
    return _status(f"{name}: tick", hw, problems, ok, [(k, v) for k, v in values if v is not None])


def _sensor_status(sensor: str, s: dict, before: dict | None, window_s: float | None, name: str,
                   hw: str) -> DiagnosticStatus:
    rendered, skipped = int(s.get("rendered", 0)), int(s.get("skipped", 0))
    values = [("enabled", bool(s.get("enabled", True))), ("target rate (Hz)", float(s.get("rate", 0.0))),
              ("rendered", rendered), ("skipped", skipped)]
    if not s.get("enabled", True):
        return _status(f"{name}: {sensor}", hw, [], "off", values)
    new_skipped, where = skipped, "since start"
    if before is not None and window_s:
        new_rendered = rendered - int(before.get("rendered", 0))
        new_skipped, where = skipped - int(before.get("skipped", 0)), f"in the last {window_s:.3g} s"
        values += [("rendered rate (Hz)", new_rendered / window_s), ("skipped rate (Hz)", new_skipped / window_s)]
    problems = [f"{new_skipped} frame(s) skipped {where} (rendering slower than {s.get('rate', 0):g} Hz)"] \
        if new_skipped > 0 else []
    return _status(f"{name}: {sensor}", hw, problems, f"{rendered} frames rendered", values)


def _command_status(refusals: dict, console: dict, name: str, hw: str) -> DiagnosticStatus:
    # refusals are the clients' mistakes, reported on `error`; they say nothing of the twin's health
    total = sum(refusals.values())
    summary = ", ".join(f"{kind} {n}" for kind, n in sorted(refusals.items()))
    message = f"{total} command(s) refused: {summary}" if total else "no command refused"
    return _status(f"{name}: commands", hw, [], message,
                   [(f"refused {kind}", int(n)) for kind, n in sorted(refusals.items())]
                   + [(f"console {kind}", int(n)) for kind, n in sorted(console.items())])


def build_diagnostics(stats: dict, stamp=None, previous: dict | None = None,
                      window_s: float | None = None) -> DiagnosticArray:
    """/diagnostics message of the twin from `stats` (above); `previous`: the stats of the last
    call, `window_s`: seconds since it (both or neither), for frame rates over that window."""
    name = str(stats.get("node", "cressim_twin"))
    hw = str(stats.get("hardware_id", name))
    msg = DiagnosticArray()
    if stamp is not None:
        msg.header.stamp = stamp
    msg.status.append(_tick_status(stats, name, hw))
    before = (previous or {}).get("sensors", {})
    for sensor, s in sorted(stats.get("sensors", {}).items()):
        msg.status.append(_sensor_status(sensor, s, before.get(sensor) if previous else None, window_s, name, hw))
    msg.status.append(_command_status(stats.get("refusals", {}), stats.get("console", {}), name, hw))
    return msg


__all__ = ["RATE_TOLERANCE", "build_diagnostics"]
