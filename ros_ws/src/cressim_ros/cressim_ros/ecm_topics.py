"""The patient cart's ECM on ROS: the dVRK's ECM topics under /ECM, wired to cressim.twin's EcmArm.

Published every tick: measured_js, setpoint_js (yaw, pitch, insertion, roll), measured_cp,
setpoint_cp (the endoscope's tip in `ECM_base`, or in the frame set by set_base_frame),
local/measured_cp, local/setpoint_cp; on events (transient local): operating_state,
desired_state, goal_reached, error, warning, status. Subscribed: state_command, servo_jp,
move_jp, servo_cp, move_cp, hold, set_base_frame. Services: operating_state, crtk_version. QoS
and message types are the PSM's (one topic table, cressim.record.schema).
"""
from __future__ import annotations

import traceback
from array import array

import numpy as np
import torch
from crtk_msgs.msg import OperatingState
from crtk_msgs.srv import TriggerOperatingState
from std_msgs.msg import Bool, String
from std_srvs.srv import Trigger

from cressim.robots.ecm import ECM_JOINT_NAMES
from cressim.robots.kinematics import matrix_to_pose7

from .topics import (CRTK_VERSION, FirstDelivery, arm_topics, fill_pose, latched_reader_qos, msg_class, on_new_reader,
                     qos)

EVENTS = ("operating_state", "desired_state", "goal_reached", "error", "warning", "status")
STATE = ("measured_js", "setpoint_js", "measured_cp", "setpoint_cp", "local/measured_cp", "local/setpoint_cp")


class EcmTopics:
    def __init__(self, node, ecm, namespace: str = "/ECM"):
        self.node, self.ecm, self.ns = node, ecm, namespace
        specs = {t.name: t for role in ("state", "event", "command") for t in arm_topics(role)}
        self.specs = specs
        again = on_new_reader(lambda: self.emit([("operating_state", ecm.report())]))
        self.pubs = {name: node.create_publisher(msg_class(specs[name]), f"{namespace}/{name}", qos(specs[name]),
                                                 **({"event_callbacks": again} if name == "operating_state" else {}))
                     for name in STATE + EVENTS}
        handlers = {"state_command": lambda m: ecm.state_command(m.string), "servo_jp": ecm.servo_jp,
                    "move_jp": ecm.move_jp, "hold": lambda m: ecm.hold(), "set_base_frame": self._set_base_frame,
                    "servo_cp": lambda m: ecm.servo_cp(m.pose), "move_cp": lambda m: ecm.move_cp(m.pose)}
        self.subs = [node.create_subscription(msg_class(specs[name]), f"{namespace}/{name}",
                                              lambda m, h=handler, n=name: self._on(n, h, m), qos(specs[name]))
                     for name, handler in handlers.items()]
        self._latched = FirstDelivery()  # state_command also through a transient-local reader (topics.py)
        self.subs.append(node.create_subscription(
            msg_class(specs["state_command"]), f"{namespace}/state_command",
            lambda m: self._on("state_command", handlers["state_command"], m),
            latched_reader_qos(specs["state_command"])))
        self.base_frame_id = f"{ecm.name}_base"
        self.services = [
            node.create_service(TriggerOperatingState, f"{namespace}/operating_state", self._srv_state),
            node.create_service(Trigger, f"{namespace}/crtk_version", self._srv_version)]
        self.emit([("operating_state", ecm.report())])

    def _out(self, name, msg):
        """Publishes on the ECM's topic `name` and records it when the node records."""
        self.pubs[name].publish(msg)
        if self.node.recorder is not None:
            self.node._record(f"{self.ns}/{name}", msg)

    def latched(self) -> list:
        """(topic, message) a new recording opens with: the ECM's state."""
        return [(f"{self.ns}/operating_state", self._state_msg(self.ecm.report()))]

    def _set_base_frame(self, msg):
        events = self.ecm.set_base_frame(msg.pose)
        if msg.header.frame_id and not any(t == "error" for t, _ in events):
            self.base_frame_id = msg.header.frame_id
        return events

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
        msg.header.stamp = self.node.stamp()
        msg.header.frame_id = self.base_frame_id
        return msg

    def emit(self, events):
        for topic, value in events:
            if topic == "operating_state":
                msg = self._state_msg(value)
            elif isinstance(value, bool):
                msg = Bool(data=value)
            else:
                msg = String(data=f"{self.ecm.name}: {value}" if topic in ("error", "warning") else str(value))
                if topic in ("error", "warning"):
                    self.node.get_logger().warning(msg.data, throttle_duration_sec=1.0)
            self._out(topic, msg)

    def publish(self, stamp):
        """The periodic topics, then the ECM's events of the tick."""
        ecm = self.ecm
        for name, q, v in (("measured_js", ecm.measured, ecm.measured_v),
                           ("setpoint_js", ecm.setpoint, ecm.setpoint_v)):
            m = msg_class(self.specs[name])()
            m.header.stamp = stamp
            m.name = list(ECM_JOINT_NAMES)
            m.position, m.velocity, m.effort = array("d", q), array("d", v), array("d", [0.0] * 4)
            self._out(name, m)
        for which in ("measured", "setpoint"):
            local = ecm.local_cp(which)
            for name, T, frame in ((f"local/{which}_cp", local, f"{ecm.name}_base"),
                                   (f"{which}_cp", ecm.base_frame @ local, self.base_frame_id)):
                m = msg_class(self.specs[name])()
                m.header.stamp, m.header.frame_id = stamp, frame
                fill_pose(m.pose, matrix_to_pose7(torch.as_tensor(T[None]))[0].numpy())
                self._out(name, m)
        self.emit(self.node.arms.ecm_events)

    def tip_pose7(self) -> np.ndarray:
        """ECM_base -> ECM (the tip) for /tf."""
        return matrix_to_pose7(torch.as_tensor(self.ecm.local_cp("measured")[None]))[0].numpy()

    def _srv_state(self, request, response):
        response.operating_state = self._state_msg(self.ecm.report())
        return response

    def _srv_version(self, request, response):
        response.success, response.message = True, CRTK_VERSION
        return response


__all__ = ["EcmTopics"]
