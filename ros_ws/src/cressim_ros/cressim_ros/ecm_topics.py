"""The patient cart's ECM on ROS: the dVRK's ECM topics under /ECM, wired to cressim.twin's EcmArm.

Published every tick: measured_js, setpoint_js (yaw, pitch, insertion, roll), measured_cp,
setpoint_cp (the endoscope's tip in `ECM_base`, or in the frame set by set_base_frame),
local/measured_cp, local/setpoint_cp; on events (transient local): operating_state,
desired_state, goal_reached, error, warning, status. Subscribed: state_command, servo_jp,
move_jp, servo_cp, move_cp, hold, set_base_frame. Services: operating_state, crtk_version. QoS
and message types are the PSM's (one topic table, cressim.record.schema); the skeleton every
cart arm shares is CrtkArmTopics.
"""
from __future__ import annotations

import numpy as np
import torch

from cressim.robots.ecm import ECM_JOINT_NAMES
from cressim.robots.kinematics import matrix_to_pose7
from cressim.twin.cart import pairs

from .crtk_arm_topics import CrtkArmTopics
from .topics import arm_topics

EVENTS = ("operating_state", "desired_state", "goal_reached", "error", "warning", "status")
STATE = ("measured_js", "setpoint_js", "measured_cp", "setpoint_cp", "local/measured_cp", "local/setpoint_cp")


class EcmTopics(CrtkArmTopics):
    def __init__(self, node, ecm, namespace: str = "/ECM"):
        self.ecm = ecm
        specs = {t.name: t for role in ("state", "event", "command") for t in arm_topics(role)}
        handlers = {"state_command": lambda m: pairs(ecm.state_command(0, m.string)),
                    "servo_jp": lambda m: pairs(ecm.servo_jp(0, m)), "move_jp": lambda m: pairs(ecm.move_jp(0, m)),
                    "hold": lambda m: pairs(ecm.hold(0)), "set_base_frame": self._set_base_frame,
                    "servo_cp": lambda m: pairs(ecm.servo_cp(0, m.pose)),
                    "move_cp": lambda m: pairs(ecm.move_cp(0, m.pose))}
        super().__init__(node, ecm, namespace, specs, STATE + EVENTS, handlers, frame=f"{ecm.name}_base")

    def _set_base_frame(self, msg):
        events = pairs(self.ecm.set_base_frame(0, msg.pose))
        if msg.header.frame_id and not any(t == "error" for t, _ in events):
            self.frame = msg.header.frame_id
        return events

    def publish(self, stamp):
        """The periodic topics, then the ECM's events of the tick."""
        ecm = self.ecm
        self.check_hold()
        self.joint_state("measured_js", stamp, ECM_JOINT_NAMES, ecm.measured[0], ecm.measured_v[0])
        self.joint_state("setpoint_js", stamp, ECM_JOINT_NAMES, ecm.setpoint[0], ecm.setpoint_v[0])
        items = []
        for which in ("measured", "setpoint"):
            local = ecm.local_cp(which)
            items += [(f"local/{which}_cp", f"{ecm.name}_base", local),
                      (f"{which}_cp", self.frame, ecm.base_frame_np[0] @ local)]
        self.poses(stamp, items)
        self.release_held()
        self.emit(self.node.arms.ecm_events)

    def tip_pose7(self) -> np.ndarray:
        """ECM_base -> ECM (the tip) for /tf."""
        return matrix_to_pose7(torch.as_tensor(self.ecm.local_cp("measured")[None]))[0].numpy()


__all__ = ["EcmTopics"]
