"""The patient cart's surgeon console on ROS: the MTMs' dVRK topics, the console's buttons, and the
operator's input, wired to cressim.twin.mtm (MtmArm, Operator). The topics are cressim.record.
schema's MTM_TOPICS and CONSOLE_TOPICS (docs/twin.md, "Patient cart"):

- each MTM (/MTML, /MTMR; CrtkArmTopics): measured_js, setpoint_js (the 7 joints), local/measured_cp
  (their FK, in the DH base), measured_cp, setpoint_cp and gripper/measured_js every tick; the
  arm's events (operating_state ...), state_command and services as a PSM's; move_cp, servo_cp,
  body/servo_cf, lock_orientation, unlock_orientation, use_gravity_compensation;
- the console's buttons (sensor_msgs/Joy), published when they change and every half second of
  simulated time (a client that joins late learns them): /footpedals/clutch, /footpedals/camera,
  /console/operator_present;
- the operator's input: /operator/clutch, /operator/camera, /operator/present (std_msgs/Bool),
  /operator/MTMx/servo_cp (the hand's position), /operator/MTMx/gripper/servo_jp (the grip).
A scripted operator (the scene's `cart.operator`) drives the same Operator without ROS.
"""
from __future__ import annotations

import math

import numpy as np
from sensor_msgs.msg import Joy

from cressim.record.schema import CONSOLE_TOPICS, MTM_TOPICS
from cressim.robots.mtm import MTM_JOINT_NAMES

from .crtk_arm_topics import CrtkArmTopics
from .topics import arm_topics, msg_class, qos

BUTTONS = {"clutch": "/footpedals/clutch", "camera": "/footpedals/camera",
           "operator_present": "/console/operator_present"}  # Operator.pedals() -> topic
MTM = {t.name: t for t in MTM_TOPICS}
CONSOLE = {t.name: t for t in CONSOLE_TOPICS}
BUTTON_PERIOD_NS = 500_000_000


class MtmTopics(CrtkArmTopics):
    def __init__(self, node, mtm):
        self.mtm = mtm
        specs = {t.name: t for role in ("event", "command") for t in arm_topics(role)}  # the arm's events
        specs.update(MTM)
        handlers = {
            "state_command": lambda m: mtm.state_command(m.string),
            "move_cp": lambda m: mtm.move_cp(m.pose),
            "servo_cp": lambda m: mtm.move_cp(m.pose, kind="servo_cp"),
            "body/servo_cf": lambda m: mtm.servo_cf([m.wrench.force.x, m.wrench.force.y, m.wrench.force.z,
                                                     m.wrench.torque.x, m.wrench.torque.y, m.wrench.torque.z]),
            "lock_orientation": lambda m: mtm.lock_orientation([m.x, m.y, m.z, m.w]),
            "unlock_orientation": lambda m: mtm.unlock_orientation(),
            "use_gravity_compensation": lambda m: setattr(mtm, "gravity_compensation", m.data) or []}
        published = ("measured_js", "setpoint_js", "local/measured_cp", "measured_cp", "setpoint_cp",
                     "gripper/measured_js", "operating_state", "desired_state", "goal_reached", "error", "warning",
                     "status")
        super().__init__(node, mtm, f"/{mtm.name}", specs, published, handlers, frame=f"{mtm.name}_base")

    def publish(self, stamp):
        mtm = self.mtm
        self.check_hold()
        self.joint_state("measured_js", stamp, MTM_JOINT_NAMES, mtm.q, mtm.q_v)
        self.joint_state("setpoint_js", stamp, MTM_JOINT_NAMES, mtm.q, mtm.q_v)
        self.poses(stamp, [("local/measured_cp", f"{mtm.name}_dh_base", mtm.local), ("measured_cp", self.frame, mtm.pose),
                           ("setpoint_cp", self.frame, mtm.pose)])
        self.joint_state("gripper/measured_js", stamp, ["gripper"], [mtm.gripper], [mtm.gripper_v])
        self.release_held()


class ConsoleTopics:
    """The MTMs, the console's buttons and the operator's input of a cart (node.cart)."""

    def __init__(self, node, cart):
        self.node, self.cart = node, cart
        self.mtms = [MtmTopics(node, mtm) for mtm in cart.mtms]
        self.button_pubs = {name: node.create_publisher(Joy, topic, qos(CONSOLE[topic]))
                            for name, topic in BUTTONS.items()}
        self._published, self._next_ns = None, 0
        sub = lambda name, callback, mtm="": node.create_subscription(  # noqa: E731
            msg_class(CONSOLE[name]), name.format(mtm=mtm), callback, qos(CONSOLE[name]))
        self.subs = [sub(f"/operator/{name}", lambda m, n=name: self._pedal(n, m))
                     for name in ("clutch", "camera", "present")]
        for mtm in cart.mtms:
            self.subs += [sub("/operator/{mtm}/servo_cp", lambda m, n=mtm.name: self._hand(n, m), mtm.name),
                          sub("/operator/{mtm}/gripper/servo_jp", lambda m, n=mtm.name: self._grip(n, m), mtm.name)]

    def _warn(self, text):
        self.node.get_logger().warning(f"operator input refused: {text}", throttle_duration_sec=1.0)

    def _pedal(self, name, msg):
        setattr(self.cart.operator, name, bool(msg.data))

    def _hand(self, name, msg):
        p = msg.pose.position
        position = np.array([p.x, p.y, p.z], dtype=np.float64)
        if not np.isfinite(position).all() or np.abs(position).max() > 1.0:
            return self._warn(f"/operator/{name}/servo_cp: position {position.tolist()} is not finite or beyond 1 m")
        self.cart.operator.hands[name] = position

    def _grip(self, name, msg):
        if len(msg.position) != 1 or not math.isfinite(msg.position[0]):
            return self._warn(f"/operator/{name}/gripper/servo_jp: one finite position expected")
        self.cart.operator.grips[name] = float(msg.position[0])

    def publish(self, stamp):
        for topics in self.mtms:
            topics.publish(stamp)
        buttons = self.cart.operator.pedals()
        now = self.cart.sim_ns
        if buttons != self._published or now >= self._next_ns:
            for name, pressed in buttons.items():
                m = Joy(buttons=[int(pressed)])
                m.header.stamp = stamp
                self.button_pubs[name].publish(m)
                if self.node.recorder is not None:
                    self.node._record(BUTTONS[name], m)
            self._published, self._next_ns = buttons, now + BUTTON_PERIOD_NS


__all__ = ["BUTTONS", "ConsoleTopics", "MtmTopics"]
