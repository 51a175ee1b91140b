"""The dVRK's own Python clients, unchanged, drive the twin: each script runs as a subprocess
(a DDS participant of its own) against a twin of its own, as a dVRK user runs it.

The clients are the third-party folder of shared/third_party/README.md: `$CRESSIM_DVRK_CLIENTS`
if set (relative to the repository root), else ../shared/third_party seen from the repository
root; without it every test here is skipped with a message naming the folder. They need PyKDL
(`make` links Debian's python3-pykdl into .venv: the `.make/pykdl` step) and every message of
crtk_msgs (ros_ws). Environment of a script: PYTHONPATH = crtk_python_client/src and
dvrk_python/src, then what ros_ws/env.sh set; ROS_VERSION=2 (crtk.ral picks its ROS 2 layer);
the twin's ROS_DOMAIN_ID; ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST; stdin a stream of newlines
(dvrk_psm_test.py waits for Enter 7 times).

Run:
- dvrk_python/scripts/dvrk_arm_test.py -a PSM1 (its own minimal arm: enable, home, move_jp,
  a servo_jp sine, move_jp, servo_cp and move_cp squares);
- dvrk_psm_test.py -a PSM1 (-a is required; -p, the servo period, defaults to 0.01 s): a
  `dvrk.psm`; the jaw closed and opened alone, beside insert_jp and beside move_cp, a 20 s jaw
  servo_jp sine between 20 and 80 degrees, then the jaw moves again;
- dvrk_move_wait_test.py -a PSM1: a `dvrk.arm`; move_jp waited with wait(), then with a busy
  loop on the handle's is_busy();
- crtk_python_client/scripts/crtk_servo_jp_example.py, crtk_servo_cp_example.py,
  crtk_servo_cv_example.py, crtk_move_cp_example.py (argument: the namespace, PSM1). These
  neither enable nor home the device (a dVRK user does that from the console first), so the
  test does it before them with crtk's own `utils` (enable, home, then move_jp to the pose the
  dVRK scripts start Cartesian motion from: insertion 0.12 m, the other joints 0);
- `dvrk.system` (code of the test's, as dvrk_system_test.py but with time for discovery): the
  console's set_volume, string_to_speech and beep, counted by the twin, a bad volume refused;

Left out:
- crtk_rate_example.py: it uses no device at all (rclpy's Rate at 1 kHz for 10 s);
- crtk_haptic_example.py: written for a haptic device (a force-output device such as a
  Phantom Omni or Falcon): it servos Cartesian forces (servo_cf: a virtual box, viscosity) and
  loops on an interactive menu until 'q';
- crtk_teleop_example.py: needs a master device (an MTM or a haptic device, its measured_cp)
  besides the PSM, and runs until Ctrl-C;
- not `crtk_*_example.py`: crtk_xyz.py (keyboard jogging) and
  crtk_simple_orientation_registration.py (a user moving an input device by hand); of the dVRK
  scripts, those for an MTM, a console, teleoperation or the real hardware.

dvrk_arm_test.py -a ECM runs against the patient cart (scenes/patient_cart.yaml): the ECM's
Cartesian goals keep the start pose's orientation while the tip moves, so they are only reached
because the twin re-aligns each goal's z to the scope's line as the dVRK's ECM does.

A script passes when it exits 0 within a safety limit (the scripts' own timeouts are their
business; this limit only catches a hang), its output shows it ran to the end (its last
lines) and holds none of its own failure reports (a line starting with '!', "failed",
"error", "exception", a traceback, "timed out"), and on the twin's side: nothing was published
on `error`, the twin is still running, neither side was told of an incompatible QoS (the
clients' writers with their own QoS), and for the silent crtk examples, the motion they
command is seen on setpoint_js / setpoint_cp (and goal_reached for move_cp). Assertion messages
carry the script's full output.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from twin_fixtures import OwnContextClient, ScriptRun

pytestmark = pytest.mark.ros

ARM = "PSM1"
SCRIPT_TIMEOUT = 300.0  # s, a safety limit only: the longest script takes about 40 s here
WAIT_TIMEOUT = 120.0  # s, safety limit on waiting for the twin's topics

# a report of the script's own failure: '  ! failed to enable', sys.exit('failed to ...'),
# a traceback, TimeoutError('Timed out waiting for ... connections'), 'Inverse kinematic error'
FAILURE = re.compile(r"^\s*!|\bfail|\berror|\bexception|\btraceback|\btimed out|\btimeout", re.I | re.M)
# ... except dvrk_arm_test's note that setpoint_cp, read right after a servo_cp, is more than 2 mm
# from it "(might be due to latency)": a twin on a loaded machine answers a few ticks later (the
# script goes on; the servo_cp motion is checked from the twin's setpoint_cp instead)
LATENCY_NOTE = re.compile(r"Inverse kinematic error in position \[\d+\]: [0-9.e-]+ \(might be due to latency\)$")


def run_python(args: list[str], clients: Path, domain: int, cwd: Path) -> tuple[int | None, str]:
    """(exit status or None after the safety limit, stdout and stderr together)."""
    with ScriptRun(clients, domain, args, cwd) as run:
        return run.wait(SCRIPT_TIMEOUT), run.output_after_exit_race()


# Before a crtk example: the device enabled, homed and at the dVRK scripts' Cartesian start pose,
# with crtk's own client code (the dVRK console's buttons, for a user).
PREPARE = f"""
import sys, numpy, crtk
class Arm:
    def __init__(self, ral):
        self.crtk_utils = crtk.utils(self, ral, 5.0)
        self.crtk_utils.add_operating_state()
        self.crtk_utils.add_setpoint_js()
        self.crtk_utils.add_move_jp()
ral = crtk.ral('cressim_prepare', '{ARM}')
arm = Arm(ral)
def run():
    ral.check_connections(60.0)
    if not arm.enable(60.0):
        sys.exit('! enable timed out, operating state: ' + repr(arm.operating_state()))
    if not arm.home(60.0):
        sys.exit('! home timed out, operating state: ' + repr(arm.operating_state()))
    jp, _ = arm.setpoint_jp(wait_timeout=60.0)
    goal = numpy.zeros(len(jp))
    goal[2] = 0.12
    if not arm.move_jp(goal).wait(timeout=120.0):
        sys.exit('! move_jp to the start pose did not finish')
    print('prepared at', arm.setpoint_jp()[0].round(6).tolist())
ral.spin_and_execute(run)
"""


class TwinWatch(OwnContextClient):
    """What the twin publishes (rclpy context of its own): everything on `error`, goal_reached,
    setpoint_js and setpoint_cp positions, in arrival order. Subscribes to no command topic, so
    that a script's check_connections still waits for the twin itself."""

    def __init__(self, domain: int, arm: str = ARM):
        from diagnostic_msgs.msg import DiagnosticArray
        from geometry_msgs.msg import PoseStamped
        from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
        from sensor_msgs.msg import JointState
        from std_msgs.msg import Bool, String

        super().__init__(domain, "dvrk_scripts_watch")
        self.errors: list[str] = []
        self.goal_reached: list[bool] = []
        self.jp: list[list[float]] = []
        self.cp: list[tuple[float, float, float]] = []
        self.commands: dict[str, int] = {}  # /diagnostics' command counts: "refused beep", "console beep" ...
        event = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE,
                           durability=DurabilityPolicy.TRANSIENT_LOCAL)  # every one since the twin started
        periodic = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)

        def keep(store, value):
            def callback(msg):
                with self.cv:
                    store.append(value(msg))
                    self.cv.notify_all()
            return callback

        ns = f"/{arm}"
        self.subscriptions = [
            self.node.create_subscription(String, f"{ns}/error", keep(self.errors, lambda m: m.data), event),
            self.node.create_subscription(Bool, f"{ns}/goal_reached", keep(self.goal_reached, lambda m: m.data), event),
            self.node.create_subscription(JointState, f"{ns}/setpoint_js", keep(self.jp, lambda m: list(m.position)),
                                          periodic),
            self.node.create_subscription(PoseStamped, f"{ns}/setpoint_cp",
                                          keep(self.cp, lambda m: (m.pose.position.x, m.pose.position.y,
                                                                   m.pose.position.z)), periodic),
            self.node.create_subscription(DiagnosticArray, "/diagnostics", self._diagnostics, periodic),
        ]
        self.start()

    def _diagnostics(self, msg):
        with self.cv:
            self.commands = {kv.key: int(kv.value) for status in msg.status for kv in status.values
                             if kv.key.startswith(("refused ", "console "))}
            self.cv.notify_all()

    def wait_commands(self, predicate) -> bool:
        """Wait until the twin's /diagnostics command counts satisfy predicate(counts)."""
        with self.cv:
            return self.cv.wait_for(lambda: predicate(self.commands), WAIT_TIMEOUT)

    def mark(self) -> dict:
        with self.cv:
            return {"goal_reached": len(self.goal_reached), "jp": len(self.jp), "cp": len(self.cp)}

    def wait_samples(self, n: int) -> bool:
        """Wait for n more setpoint_js and setpoint_cp messages (ticks of the twin)."""
        with self.cv:
            jp, cp = len(self.jp) + n, len(self.cp) + n
            return self.cv.wait_for(lambda: len(self.jp) >= jp and len(self.cp) >= cp, WAIT_TIMEOUT)

    def since(self, mark: dict) -> dict:
        with self.cv:
            return {"goal_reached": self.goal_reached[mark["goal_reached"]:], "jp": self.jp[mark["jp"]:],
                    "cp": self.cp[mark["cp"]:], "errors": list(self.errors)}


def swept(values, index) -> float:
    column = [v[index] for v in values]
    return max(column) - min(column) if column else 0.0


# What the silent crtk examples command, as the twin's setpoints show it (90 % of the amplitude:
# the twin samples a 200 Hz command stream at its own rate).
def servo_jp_sine(seen) -> list[str]:  # joints 0 and 1: +-10 degrees
    want = 0.9 * 2 * math.radians(10.0)
    return [f"setpoint_js joint {j} swept {swept(seen['jp'], j):.4f} rad, expected about {want / 0.9:.4f}"
            for j in (0, 1) if swept(seen["jp"], j) < want]


def servo_cp_cosine(seen) -> list[str]:  # x and y: 0 .. 4 cm and back
    return [f"setpoint_cp {'xy'[k]} swept {swept(seen['cp'], k):.4f} m, expected about 0.04"
            for k in (0, 1) if swept(seen["cp"], k) < 0.9 * 0.04]


def move_cp_diagonal(seen) -> list[str]:  # +2 cm, -2 cm in x and y, back: three moves
    problems = servo_cp_cosine(seen)
    if sum(seen["goal_reached"]) < 3:
        problems.append(f"goal_reached true {sum(seen['goal_reached'])} times, expected 3 (one per move_cp)")
    return problems


def servo_cv_x(seen) -> list[str]:  # 1 mm/s along x for 10 s, then zero
    # the twin integrates the twist over simulated time, one 10 ms period a tick: 10 um a tick
    # while it is on, however many ticks a loaded machine fits in the script's 10 s
    steps = np.diff([v[0] for v in seen["cp"]])
    moving = steps[np.abs(steps) > 1e-7]
    if len(moving) < 100:
        return [f"setpoint_cp x moved on {len(moving)} ticks, expected a twist held for seconds"]
    per_tick = float(np.median(moving))
    return ([] if abs(per_tick - 1e-5) < 0.05e-5 else
            [f"setpoint_cp x moved {per_tick * 1e6:.2f} um a tick, expected 10 (1 mm/s x 10 ms)"])


@dataclass(frozen=True)
class Script:
    path: str  # in the clients folder
    args: tuple = ()
    ends: tuple = ()  # (text, times): what the script prints when it gets to the end
    prepare: bool = False  # enable, home and go to the Cartesian start pose first
    check: object = None  # check(seen) -> problems, from what the twin published meanwhile


SCRIPTS = {
    "dvrk_arm_test": Script("dvrk_python/scripts/dvrk_arm_test.py", ("-a", ARM),
                            ends=(("< move_cp complete", 1), (">> illustrating user defined shutdown callback", 1)),
                            check=servo_cp_cosine),
    "dvrk_psm_test": Script("dvrk_python/scripts/dvrk_psm_test.py", ("-a", ARM),
                            ends=(("starting jaw servo", 1), ("moving back (3)", 2))),
    "dvrk_move_wait_test": Script("dvrk_python/scripts/dvrk_move_wait_test.py", ("-a", ARM),
                                  ends=(("--> You can change the trajectory velocity", 1),)),
    "crtk_servo_jp_example": Script("crtk_python_client/scripts/crtk_servo_jp_example.py", (ARM,),
                                    prepare=True, check=servo_jp_sine),
    "crtk_servo_cp_example": Script("crtk_python_client/scripts/crtk_servo_cp_example.py", (ARM,),
                                    prepare=True, check=servo_cp_cosine),
    "crtk_servo_cv_example": Script("crtk_python_client/scripts/crtk_servo_cv_example.py", (ARM,),
                                    prepare=True, check=servo_cv_x),
    "crtk_move_cp_example": Script("crtk_python_client/scripts/crtk_move_cp_example.py", (ARM,),
                                   prepare=True, check=move_cp_diagonal),
}


def _report(name, rc, output, problems, twin) -> str:
    tail = "\n".join(twin.output().splitlines()[-30:])
    return (f"{name}: " + "; ".join(problems) + f"\n----- exit status {rc}, its output:\n{output}"
            f"\n----- the twin's log (last lines):\n{tail}")


@pytest.mark.parametrize("name", list(SCRIPTS))
def test_dvrk_script(name, clients, ros_domain_id, start_twin, tmp_path):
    script = SCRIPTS[name]
    twin = start_twin(ros_domain_id)
    watch = TwinWatch(ros_domain_id)
    try:
        assert watch.wait_samples(1), f"no setpoint_js/setpoint_cp from the twin:\n{twin.output()}"
        if script.prepare:
            rc, output = run_python(["-c", PREPARE], clients, ros_domain_id, tmp_path)
            assert rc == 0 and "prepared at" in output and not FAILURE.search(output), \
                _report(f"{name} (enable, home, start pose before it)", rc, output, ["preparing failed"], twin)
        mark = watch.mark()
        rc, output = run_python([clients / script.path, *script.args], clients, ros_domain_id, tmp_path)
        # the twin's messages about the script's last commands: a few ticks later they are here
        assert watch.wait_samples(20), f"the twin stopped publishing:\n{twin.output()}"
        seen = watch.since(mark)
    finally:
        watch.close()

    problems = []
    if rc != 0:
        problems.append("no exit status (killed)" if rc is None else f"exit status {rc}")
    problems += [f"its output reports a failure: {line.strip()!r}" for line in output.splitlines()
                 if FAILURE.search(line) and not LATENCY_NOTE.search(line.strip())][:5]
    problems += [f"it did not get to the end: {text!r} printed {output.count(text)} times, expected {n}"
                 for text, n in script.ends if output.count(text) < n]
    problems += [f"the twin published on error: {e!r}" for e in seen["errors"][:5]]
    problems += [f"{who} was told of an incompatible QoS" for who, text in (("the script", output),
                                                                          ("the twin", twin.output()))
                 if "incompatible QoS" in text]
    if script.check is not None:
        problems += script.check(seen)
    if not twin.alive():
        problems.append("the twin exited")
    assert not problems, _report(name, rc, output, problems, twin)


def test_dvrk_arm_test_drives_the_carts_ecm(clients, ros_domain_id, start_twin, tmp_path):
    """dvrk_arm_test.py -a ECM, unchanged, against the patient cart: it runs to the end with no
    failure and no error from the twin, its servo_cp sweeps the scope's tip 4 cm in x and y and
    its move_cp squares end with goal_reached (every goal re-aligned to the scope's line)."""
    twin = start_twin(ros_domain_id, "scene:=patient_cart.yaml")
    watch = TwinWatch(ros_domain_id, "ECM")
    try:
        assert watch.wait_samples(1), f"no setpoint_js/setpoint_cp from the ECM:\n{twin.output()}"
        mark = watch.mark()
        rc, output = run_python([clients / "dvrk_python/scripts/dvrk_arm_test.py", "-a", "ECM"], clients,
                                ros_domain_id, tmp_path)
        assert watch.wait_samples(20), f"the twin stopped publishing:\n{twin.output()}"
        seen = watch.since(mark)
    finally:
        watch.close()
    problems = [] if rc == 0 else ["no exit status (killed)" if rc is None else f"exit status {rc}"]
    problems += [f"its output reports a failure: {line.strip()!r}" for line in output.splitlines()
                 if FAILURE.search(line) and not LATENCY_NOTE.search(line.strip())][:5]
    problems += [f"it did not get to the end: {text!r} printed {output.count(text)} times, expected {n}"
                 for text, n in SCRIPTS["dvrk_arm_test"].ends if output.count(text) < n]
    problems += [f"the twin published on /ECM/error: {e!r}" for e in seen["errors"][:5]]
    problems += servo_cp_cosine(seen)
    if sum(seen["goal_reached"]) < 6:
        problems.append(f"goal_reached true {sum(seen['goal_reached'])} times, expected 6 or more (the move_cp squares)")
    if not twin.alive():
        problems.append("the twin exited")
    assert not problems, _report("dvrk_arm_test -a ECM", rc, output, problems, twin)


# dvrk.system's sounds, with the dVRK's own client (dvrk_system_test.py does the same but gives
# discovery 2 s, too little on a loaded machine): a volume beyond 1, words, a beep (one message
# each: its writers keep only the last, so a second one sent at once may replace the first);
# then it waits to be stopped, so that its messages are not lost as it exits.
SYSTEM = """
import time, crtk, dvrk
ral = crtk.ral('cressim_system')
system = dvrk.system(ral)
def run():
    ral.check_connections(60.0)
    system.set_volume(1.5)
    system.string_to_speech('Hello D V R K')
    system.beep(0.2, 50000.0, 0.5)
    print('sent', flush=True)
    while not ral.is_shutdown():
        time.sleep(0.1)
ral.spin_and_execute(run)
"""


def test_dvrk_system_sounds(clients, ros_domain_id, start_twin, tmp_path):
    """The dVRK's `dvrk.system` finds a peer for every topic it publishes (/system/set_volume,
    beep, string_to_speech among them); each command is counted in /diagnostics, the bad volume
    refused with its reason in the twin's log; nothing is published on a PSM's `error`."""
    twin = start_twin(ros_domain_id)
    watch = TwinWatch(ros_domain_id)
    want = {"console set_volume": 1, "console string_to_speech": 1, "console beep": 1, "refused set_volume": 1}
    try:
        with ScriptRun(clients, ros_domain_id, ["-c", SYSTEM], tmp_path) as run:
            ok = watch.wait_commands(lambda counts: all(counts.get(k) == n for k, n in want.items()))
            assert ok, f"counts {watch.commands}, expected {want}\n{run.output()}\n{twin.output()[-3000:]}"
            assert "sent" in run.output() and not FAILURE.search(run.output()), run.output()
        errors = watch.since(watch.mark())["errors"]
    finally:
        watch.close()
    output = twin.output()
    assert "(the twin has no speaker)" in output and "incompatible QoS" not in output, output[-3000:]
    assert "incompatible QoS" not in run.output(), run.output()
    assert "console set_volume refused: volume 1.5 is not within [0, 1]" in output, output[-3000:]
    assert not errors and twin.alive(), errors
