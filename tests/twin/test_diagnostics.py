"""cressim_ros.diagnostics: the twin's DiagnosticArray from plain numbers (no node)."""
import pytest

pytest.importorskip("diagnostic_msgs.msg")
from diagnostic_msgs.msg import DiagnosticStatus  # noqa: E402

from cressim_ros.diagnostics import build_diagnostics  # noqa: E402


def healthy(**changes):
    stats = dict(node="cressim_twin", period_ms=10.0, tick_mean_ms=4.3, tick_max_ms=6.1, publish_rate_hz=99.8,
                 target_rate_hz=100.0, num_envs=1, refusals={},
                 sensors={"camera": dict(rate=30.0, rendered=300, skipped=0, enabled=True),
                          "ultrasound": dict(rate=10.0, rendered=0, skipped=0, enabled=False)})
    stats.update(changes)
    return stats


def by_name(msg):
    return {s.name: s for s in msg.status}


def values(status):
    return {kv.key: kv.value for kv in status.values}


def test_a_healthy_twin_is_ok_and_says_its_numbers():
    from builtin_interfaces.msg import Time
    msg = build_diagnostics(healthy(), stamp=Time(sec=5, nanosec=7))
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec) == (5, 7)
    status = by_name(msg)
    assert set(status) == {"cressim_twin: tick", "cressim_twin: camera", "cressim_twin: ultrasound",
                           "cressim_twin: commands"}
    assert all(s.level == DiagnosticStatus.OK for s in msg.status)
    assert all(s.hardware_id == "cressim_twin" for s in msg.status)
    tick = status["cressim_twin: tick"]
    assert values(tick) == {"tick mean (ms)": "4.30", "tick max (ms)": "6.10", "period (ms)": "10.00",
                            "measured_js rate (Hz)": "99.80", "target rate (Hz)": "100.00", "envs": "1"}
    assert tick.message == "tick mean 4.3 ms, tick max 6.1 ms, measured_js 99.8 Hz"
    assert status["cressim_twin: ultrasound"].message == "off"
    assert values(status["cressim_twin: camera"])["rendered"] == "300"
    assert status["cressim_twin: commands"].message == "no command refused"


@pytest.mark.parametrize("changes, words", [
    (dict(tick_max_ms=14.0), "overran its 10.0 ms period (max 14.0 ms)"),
    (dict(tick_mean_ms=11.0, tick_max_ms=14.0), "11.0 ms on average"),
    (dict(publish_rate_hz=80.0), "measured_js at 80.0 Hz of 100 Hz"),
])
def test_tick_overruns_and_slow_rates_warn(changes, words):
    tick = by_name(build_diagnostics(healthy(**changes)))["cressim_twin: tick"]
    assert tick.level == DiagnosticStatus.WARN and words in tick.message, tick.message


def test_no_rate_yet_is_not_a_warning():
    tick = by_name(build_diagnostics(healthy(publish_rate_hz=0.0)))["cressim_twin: tick"]
    assert tick.level == DiagnosticStatus.OK


def test_skipped_frames_warn_over_the_window_when_previous_stats_are_given():
    before = healthy()
    before["sensors"]["camera"].update(rendered=270, skipped=3)
    now = healthy()
    now["sensors"]["camera"].update(rendered=300, skipped=3)
    camera = by_name(build_diagnostics(now))["cressim_twin: camera"]
    assert camera.level == DiagnosticStatus.WARN and "3 frame(s) skipped since start" in camera.message
    camera = by_name(build_diagnostics(now, previous=before, window_s=1.0))["cressim_twin: camera"]
    assert camera.level == DiagnosticStatus.OK  # none skipped in the last second
    assert values(camera)["rendered rate (Hz)"] == "30.00" and values(camera)["skipped rate (Hz)"] == "0.00"
    now["sensors"]["camera"].update(rendered=315, skipped=18)
    camera = by_name(build_diagnostics(now, previous=before, window_s=1.0))["cressim_twin: camera"]
    assert camera.level == DiagnosticStatus.WARN and "15 frame(s) skipped in the last 1 s" in camera.message
    assert values(camera)["rendered rate (Hz)"] == "45.00"


def test_console_commands_are_counted_beside_refusals():
    stats = healthy(refusals={"beep": 1}, console={"beep": 2, "string_to_speech": 1})
    commands = by_name(build_diagnostics(stats))["cressim_twin: commands"]
    assert commands.level == DiagnosticStatus.OK and commands.message == "1 command(s) refused: beep 1"
    assert values(commands) == {"refused beep": "1", "console beep": "2", "console string_to_speech": "1"}


def test_refusals_are_counted_per_kind_and_do_not_warn():
    commands = by_name(build_diagnostics(healthy(refusals={"servo_jp": 3, "move_cp": 1})))["cressim_twin: commands"]
    assert commands.level == DiagnosticStatus.OK
    assert commands.message == "4 command(s) refused: move_cp 1, servo_jp 3"
    assert values(commands) == {"refused move_cp": "1", "refused servo_jp": "3"}


def test_missing_numbers_are_left_out():
    msg = build_diagnostics({"node": "twin"})
    assert [s.name for s in msg.status] == ["twin: tick", "twin: commands"]
    assert values(msg.status[0]) == {} and msg.status[0].level == DiagnosticStatus.OK
    assert msg.status[0].message == "no tick measured yet"
