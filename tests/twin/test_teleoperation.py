"""The dVRK's own teleoperation, unchanged, on the patient cart: dvrk_python/scripts/
dvrk_teleoperation.py (MTMR -> PSM1) runs as a subprocess against a twin started with
scenes/patient_cart.yaml, and this test is the surgeon: it sits down (operator present), pinches
the gripper (the script's sign that the operator is ready), moves the hand, presses the clutch,
moves the hand again, releases it, moves once more (the operator's input topics, /operator/*).

Checked: following, PSM1's tip moves by the hand's motion times the script's scale (0.2) in the
endoscope's frame: in PSM1's measured_cp (which the cart expresses in the `ECM` frame) and, from
the arm's own local/measured_cp and the scene's base poses, in the world rotated by the ECM's tip
orientation; clutched, the tip stays where it is while the hand moves; released, it follows again
from where it stopped (no jump). Then the camera pedal: with the ECM enabled and homed, the
hands' midpoint moves the endoscope's tip as much in the camera's frame (ECM's local/measured_cp
and measured_js), while PSM1 holds (its own local/measured_cp) though the script keeps sending;
and MTMR's measured_js gives its local/measured_cp and measured_cp by the dVRK's MTM kinematics.
Waits are on the script's effect (its servo_cp stream to PSM1, the tips settling), never on a
timing; wall-clock limits only catch a hang.
"""
from __future__ import annotations

import time

import numpy as np
import pytest
from twin_fixtures import OwnContextClient, ScriptRun

from cressim.robots.ecm import ecm_forward_kinematics
from cressim.robots.mtm import mtm_forward_kinematics
from cressim.robots.kinematics import pose7_to_matrix
from cressim.twin import load_scene

pytestmark = pytest.mark.ros

SCALE = 0.2  # dvrk_teleoperation.py's
HANG = 180.0  # s: a safety limit on each wait
TOLERANCE = 5e-4  # m on a tip motion of about 9 mm


def _pose(m):
    p, q = m.pose.position, m.pose.orientation
    return pose7_to_matrix(np.array([p.x, p.y, p.z, q.x, q.y, q.z, q.w]))


class Surgeon(OwnContextClient):
    """The operator's input devices and what they watch, in a context of their own."""

    def __init__(self, domain: int):
        from geometry_msgs.msg import PoseStamped
        from sensor_msgs.msg import JointState
        from std_msgs.msg import Bool

        self.PoseStamped, self.JointState, self.Bool = PoseStamped, JointState, Bool
        super().__init__(domain, "surgeon")
        self.servo_cp = 0
        self.latest, self.count = {}, {}
        pub = lambda kind, topic: self.node.create_publisher(kind, topic, 10)  # noqa: E731
        self.present_pub, self.clutch_pub = pub(Bool, "/operator/present"), pub(Bool, "/operator/clutch")
        self.camera_pub = pub(Bool, "/operator/camera")
        self.hand_pub = pub(PoseStamped, "/operator/MTMR/servo_cp")
        self.left_hand_pub = pub(PoseStamped, "/operator/MTML/servo_cp")
        from crtk_msgs.msg import StringStamped
        self.StringStamped = StringStamped
        self.ecm_command_pub = pub(StringStamped, "/ECM/state_command")
        self.joints = {}
        for topic in ("/ECM/measured_js", "/MTMR/measured_js"):
            self.node.create_subscription(JointState, topic, lambda m, t=topic: self._keep_joints(t, m), 10)
        self.grip_pub = pub(JointState, "/operator/MTMR/gripper/servo_jp")
        self.node.create_subscription(PoseStamped, "/PSM1/servo_cp", self._on_servo, 10)
        from crtk_msgs.msg import OperatingState
        self.seen = []
        for arm in ("PSM1", "MTMR", "ECM"):
            self.node.create_subscription(  # what the arms said, for failure messages
                OperatingState, f"/{arm}/operating_state",
                lambda m, a=arm: self.seen.append((a, m.state, m.is_homed, m.is_busy)), 10)
        for topic in ("/PSM1/measured_cp", "/PSM1/local/measured_cp", "/ECM/local/measured_cp", "/MTMR/measured_cp",
                      "/MTMR/local/measured_cp"):
            self.node.create_subscription(PoseStamped, topic, lambda m, t=topic: self._keep(t, m), 10)
        self.start()

    def _on_servo(self, msg):
        with self.cv:
            self.servo_cp += 1
            self.cv.notify_all()

    def _keep(self, topic, msg):
        with self.cv:
            self.latest[topic] = (_pose(msg), msg.header.frame_id)
            self.count[topic] = self.count.get(topic, 0) + 1
            self.cv.notify_all()

    def _keep_joints(self, topic, msg):
        with self.cv:
            self.joints[topic] = np.array(msg.position)
            self.cv.notify_all()

    def hand(self, position, pub=None):
        m = self.PoseStamped()
        m.pose.position.x, m.pose.position.y, m.pose.position.z = map(float, position)
        m.pose.orientation.w = 1.0
        (pub or self.hand_pub).publish(m)

    def ecm_command(self, command):
        self.ecm_command_pub.publish(self.StringStamped(string=command))

    def ecm_ready(self) -> bool:
        return any(a == "ECM" and state == "ENABLED" and homed and not busy for a, state, homed, busy in self.seen)

    def grip(self, angle):
        self.grip_pub.publish(self.JointState(position=[float(angle)]))

    def button(self, pub, pressed):
        pub.publish(self.Bool(data=bool(pressed)))

    def move_hand(self, start, goal, steps=20):
        for s in np.linspace(0.0, 1.0, steps):
            self.hand(start + s * (goal - start))
            time.sleep(0.05)
        return goal

    def wait_servo(self, count, what, output):
        with self.cv:
            target = self.servo_cp + count
            assert self.cv.wait_for(lambda: self.servo_cp >= target, HANG), f"{what}\n{output()}"

    def tip(self, topic="/PSM1/measured_cp"):
        with self.cv:
            return self.latest[topic]

    def settled(self, output, topic="/PSM1/measured_cp", still=2e-5, commands=2):
        """The poses once `topic`'s has stopped: 10 consecutive readings of it within `still`,
        spanning `commands` of the script's servo_cp (it sends a few a second: a tip is also still
        between two of them; 0 while it sends none, clutched)."""
        deadline, last, calm, since = time.monotonic() + HANG, None, 0, 0
        while time.monotonic() < deadline:
            with self.cv:
                seen = self.count.get(topic, 0)
                self.cv.wait_for(lambda: self.count.get(topic, 0) > seen, 1.0)
                T = self.latest.get(topic, (None,))[0]
                servo = self.servo_cp
            if T is not None and last is not None and np.linalg.norm(T[:3, 3] - last) < still:
                calm += 1
                if calm >= 10 and servo - since >= commands:
                    return {t: v[0] for t, v in self.latest.items()}
            else:
                calm, since = 0, servo
            last = None if T is None else T[:3, 3].copy()
        raise AssertionError(f"{topic} never settled\n{output()}")


def test_dvrk_teleoperation_follows_in_the_camera_frame_and_clutches(start_twin, ros_domain_id, clients, tmp_path):
    start_twin(ros_domain_id, "scene:=patient_cart.yaml")
    script = clients / "dvrk_python" / "scripts" / "dvrk_teleoperation.py"
    # -i 0.25: its period, and 4 x it is how old the MTM's data may be before it gives up (1 s
    # here: a loaded 2-core machine may hold a tick for a few hundred ms)
    run = ScriptRun(clients, ros_domain_id, [script, "-m", "MTMR", "-p", "PSM1", "-o", "/console/operator_present",
                                             "-i", "0.25"], tmp_path)
    output = run.output
    surgeon = Surgeon(ros_domain_id)
    try:
        hand = np.array([0.0, 0.0, 0.0])
        surgeon.hand(hand)
        surgeon.button(surgeon.present_pub, True)
        # pinch until the script follows (its servo_cp stream to PSM1 starts)
        deadline = time.monotonic() + HANG
        k = 0
        while surgeon.servo_cp == 0:
            assert run.running(), f"dvrk_teleoperation.py exited\n{output()}\n{surgeon.seen}"
            assert time.monotonic() < deadline, f"teleoperation never followed\n{output()}"
            surgeon.button(surgeon.present_pub, True)
            surgeon.hand(hand)
            surgeon.grip(0.3 if k % 2 else 0.6)
            k += 1
            time.sleep(0.3)
        surgeon.grip(0.5)
        surgeon.wait_servo(5, "following stopped", output)
        before = surgeon.settled(output)

        # following: the tip moves by the scaled hand motion, in the endoscope's frame
        d = np.array([0.03, -0.02, 0.025])
        hand = surgeon.move_hand(hand, hand + d)
        surgeon.wait_servo(5, "following stopped", output)
        after = surgeon.settled(output)
        assert surgeon.tip()[1] == "ECM"  # measured_cp's frame: the endoscope's
        moved = after["/PSM1/measured_cp"][:3, 3] - before["/PSM1/measured_cp"][:3, 3]
        assert np.linalg.norm(moved - SCALE * d) < TOLERANCE, (moved, SCALE * d, output())
        # the same motion from the arm's own frame and the scene's bases: R_world_camera (0.2 d)
        scene = load_scene("patient_cart.yaml")
        base = {a.name: pose7_to_matrix(np.array([*a.base_position, *a.base_rotation])) for a in scene.cart}
        camera = base["ECM"] @ after["/ECM/local/measured_cp"]
        world = [base["PSM1"] @ s["/PSM1/local/measured_cp"] for s in (before, after)]
        assert np.linalg.norm((world[1] - world[0])[:3, 3] - camera[:3, :3] @ (SCALE * d)) < TOLERANCE
        assert np.allclose(camera, base["ECM"] @ ecm_forward_kinematics(np.array(scene.cart[0].home_jp)), atol=1e-6)

        # clutched: the tip stays while the hand moves
        surgeon.button(surgeon.clutch_pub, True)
        count = surgeon.servo_cp
        time.sleep(2.0)  # the script's next periods: it holds PSM1 and stops its servo_cp stream
        stopped_at = surgeon.servo_cp
        hand = surgeon.move_hand(hand, hand + np.array([-0.04, 0.03, 0.0]))
        time.sleep(2.0)
        assert surgeon.servo_cp == stopped_at and stopped_at >= count, "no servo_cp while clutched"
        held = surgeon.settled(output, commands=0)
        assert np.linalg.norm(held["/PSM1/measured_cp"][:3, 3] - after["/PSM1/measured_cp"][:3, 3]) < 2e-4

        # released: following again from where the tip stopped
        surgeon.button(surgeon.clutch_pub, False)
        surgeon.wait_servo(5, "teleoperation did not follow again after the clutch", output)
        resumed = surgeon.settled(output)
        assert np.linalg.norm(resumed["/PSM1/measured_cp"][:3, 3] - held["/PSM1/measured_cp"][:3, 3]) < 2e-4
        d3 = np.array([0.0, 0.02, -0.02])
        hand = surgeon.move_hand(hand, hand + d3)
        surgeon.wait_servo(5, "following stopped", output)
        last = surgeon.settled(output)
        moved = last["/PSM1/measured_cp"][:3, 3] - resumed["/PSM1/measured_cp"][:3, 3]
        assert np.linalg.norm(moved - SCALE * d3) < TOLERANCE, (moved, SCALE * d3, output())

        # the camera pedal: the hands' midpoint moves the endoscope, PSM1 holds
        surgeon.ecm_command("enable")
        surgeon.ecm_command("home")
        deadline = time.monotonic() + HANG
        while not surgeon.ecm_ready():
            assert time.monotonic() < deadline, f"the ECM never got ready: {surgeon.seen}"
            time.sleep(0.1)
        surgeon.hand(np.zeros(3), surgeon.left_hand_pub)  # MTML held where it is (its home)
        start = surgeon.settled(output, "/ECM/local/measured_cp")
        q_start = surgeon.joints["/ECM/measured_js"].copy()
        surgeon.button(surgeon.camera_pub, True)
        time.sleep(1.0)  # the press reaches the twin (the script goes on sending; PSM1 holds)
        d4 = np.array([0.04, -0.02, 0.03])
        hand = surgeon.move_hand(hand, hand + d4)  # MTMR only: the midpoint moves by half of it
        moved_ecm = surgeon.settled(output, "/ECM/local/measured_cp")
        steered = moved_ecm["/ECM/local/measured_cp"][:3, 3] - start["/ECM/local/measured_cp"][:3, 3]
        assert np.linalg.norm(steered - start["/ECM/local/measured_cp"][:3, :3] @ (d4 / 2)) < TOLERANCE, \
            (steered, output())
        assert np.linalg.norm(surgeon.joints["/ECM/measured_js"] - q_start) > 0.01
        assert np.linalg.norm(moved_ecm["/PSM1/local/measured_cp"][:3, 3]
                              - start["/PSM1/local/measured_cp"][:3, 3]) < 2e-4
        # MTMR's joints, by the dVRK's MTM kinematics, are its Cartesian pose
        with surgeon.cv:
            q_mtm = surgeon.joints["/MTMR/measured_js"].copy()
            local, cp = surgeon.latest["/MTMR/local/measured_cp"][0], surgeon.latest["/MTMR/measured_cp"][0]
        assert q_mtm.shape == (7,)
        assert np.allclose(mtm_forward_kinematics("MTMR", q_mtm), local, atol=1e-6)
        assert np.allclose(cp[:3, 3], hand, atol=1e-6)  # measured_cp: where the hand holds the grip
        surgeon.button(surgeon.camera_pub, False)
        assert run.running(), f"dvrk_teleoperation.py exited\n{output()}"
    finally:
        surgeon.close()
        run.stop()
