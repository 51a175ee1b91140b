"""The patient cart's surgeon console on ROS: the MTMs' dVRK topics, the console's buttons, and the
operator's input, wired to cressim.twin.mtm (MtmArm, Operator). The topics are cressim.record.
schema's MTM_TOPICS and CONSOLE_TOPICS (docs/twin.md, "Patient cart"):

- each MTM (/MTML, /MTMR): measured_cp, setpoint_cp and gripper/measured_js every tick; the
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
import traceback
from array import array

import numpy as np
import torch
from crtk_msgs.msg import OperatingState, StringStamped
from crtk_msgs.srv import TriggerOperatingState
from geometry_msgs.msg import PoseStamped
from sensor_msgs.msg import JointState, Joy
from std_msgs.msg import Bool, String
from std_srvs.srv import Trigger

from cressim.record.schema import CONSOLE_TOPICS, MTM_TOPICS
from cressim.robots.kinematics import matrix_to_pose7

from .topics import (CRTK_VERSION, FirstDelivery, arm_topics, fill_pose, latched_reader_qos, msg_class, on_new_reader,
                     qos)

BUTTONS = {"clutch": "/footpedals/clutch", "camera": "/footpedals/camera",
           "operator_present": "/console/operator_present"}  # Operator.pedals() -> topic
MTM = {t.name: t for t in MTM_TOPICS}
CONSOLE = {t.name: t for t in CONSOLE_TOPICS}
BUTTON_PERIOD_NS = 500_000_000


class MtmTopics:
    def __init__(self, node, mtm):
        self.node, self.mtm, ns = node, mtm, f"/{mtm.name}"
        specs = {t.name: t for role in ("event", "command") for t in arm_topics(role)}  # the arm's events
        specs.update(MTM)
        again = on_new_reader(lambda: self.emit([("operating_state", mtm.report())]))
        self.pubs = {name: node.create_publisher(
            msg_class(specs[name]), f"{ns}/{name}", qos(specs[name]),
            **({"event_callbacks": again} if name == "operating_state" else {}))
            for name in ("measured_cp", "setpoint_cp", "gripper/measured_js", "operating_state", "desired_state",
                         "goal_reached", "error", "warning", "status")}
        handlers = {
            "state_command": lambda m: mtm.state_command(m.string),
            "move_cp": lambda m: mtm.move_cp(m.pose),
            "servo_cp": lambda m: mtm.move_cp(m.pose, kind="servo_cp"),
            "body/servo_cf": lambda m: mtm.servo_cf([m.wrench.force.x, m.wrench.force.y, m.wrench.force.z,
                                                     m.wrench.torque.x, m.wrench.torque.y, m.wrench.torque.z]),
            "lock_orientation": lambda m: mtm.lock_orientation([m.x, m.y, m.z, m.w]),
            "unlock_orientation": lambda m: mtm.unlock_orientation(),
            "use_gravity_compensation": lambda m: setattr(mtm, "gravity_compensation", m.data) or []}
        self.subs = [node.create_subscription(msg_class(specs[name]), f"{ns}/{name}",
                                              lambda m, h=h, n=name: self._on(n, h, m), qos(specs[name]))
                     for name, h in handlers.items()]
        self._latched = FirstDelivery()  # state_command also through a transient-local reader (topics.py)
        self.subs.append(node.create_subscription(StringStamped, f"{ns}/state_command",
                                                  lambda m: self._on("state_command", handlers["state_command"], m),
                                                  latched_reader_qos(specs["state_command"])))
        self.services = [node.create_service(TriggerOperatingState, f"{ns}/operating_state", self._srv_state),
                         node.create_service(Trigger, f"{ns}/crtk_version", self._srv_version)]
        self.frame = f"{mtm.name}_base"
        self.emit([("operating_state", mtm.report())])

    def _out(self, name, msg):
        """Publishes on the MTM's topic `name` and records it when the node records."""
        self.pubs[name].publish(msg)
        if self.node.recorder is not None:
            self.node._record(f"/{self.mtm.name}/{name}", msg)

    def latched(self) -> list:
        """(topic, message) a new recording opens with: the MTM's state."""
        return [(f"/{self.mtm.name}/operating_state", self._state_msg(self.mtm.report()))]

    def _on(self, name, handler, msg):
        if name == "state_command" and not self._latched.first(name, msg):
            return  # the same command through the other reader
        try:
            self.emit(handler(msg))
        except Exception as exc:  # noqa: BLE001 - the node must survive any message
            self.emit([("error", f"{name}: internal error, command ignored ({type(exc).__name__}: {exc})")])
            self.node.get_logger().error(traceback.format_exc(), throttle_duration_sec=1.0)

    def _state_msg(self, report):
        msg = OperatingState(state=report.state, is_homed=report.is_homed, is_busy=report.is_busy)
        msg.header.stamp, msg.header.frame_id = self.node.stamp(), self.frame
        return msg

    def emit(self, events):
        for topic, value in events:
            if topic == "operating_state":
                msg = self._state_msg(value)
            elif isinstance(value, bool):
                msg = Bool(data=value)
            else:
                text = f"{self.mtm.name}: {value}" if topic in ("error", "warning") else str(value)
                msg = String(data=text)
                if topic in ("error", "warning"):
                    self.node.get_logger().warning(text, throttle_duration_sec=1.0)
            self._out(topic, msg)

    def publish(self, stamp):
        pose = matrix_to_pose7(torch.as_tensor(self.mtm.pose[None]))[0].numpy()
        for name in ("measured_cp", "setpoint_cp"):
            m = PoseStamped()
            m.header.stamp, m.header.frame_id = stamp, self.frame
            fill_pose(m.pose, pose)
            self._out(name, m)
        m = JointState(name=["gripper"])
        m.header.stamp = stamp
        m.position, m.velocity, m.effort = array("d", [self.mtm.gripper]), array("d", [self.mtm.gripper_v]), \
            array("d", [0.0])
        self._out("gripper/measured_js", m)

    def _srv_state(self, request, response):
        response.operating_state = self._state_msg(self.mtm.report())
        return response

    def _srv_version(self, request, response):
        response.success, response.message = True, CRTK_VERSION
        return response


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
