"""One CRTK arm of the cart on ROS (the ECM, an MTM): what every such arm's topics share.

    topics = CrtkArmTopics(node, arm, "/ECM", specs, published, handlers, frame="ECM_base")
    topics.emit(arm.state_command("enable"))   # (topic, value) events -> messages
    topics.joint_state("measured_js", stamp, names, q, v)
    topics.poses(stamp, [("measured_cp", frame, T), ...])
    topics.check_hold(); ...the tick's samples...; topics.release_held()   # each tick

`arm` has a `name`, `report()` (a StateReport) and `state_command(text)`. Publishers of the
`published` topics (operating_state says the state again to each new reader: crtk's readers are
volatile), a subscription per `handlers` entry (name -> fn(msg) -> events; an exception becomes
an `error` event, the node goes on), `state_command` through topics.LatchedCommandReader (crtk
latches it: what it sent before the readers matched still comes; each command once), the
`operating_state` and `crtk_version` services. Every message, published or received, is
recorded when the node records.
QoS and types are cressim.record.schema's (`specs`). The operating_state that answers `home`
waits until the arm's state topics have their readers (homed_hold.py), checked each tick by
`check_hold` and `release_held` around the tick's samples.
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

from cressim.robots.kinematics import matrix_to_pose7

from .homed_hold import HomedHold, readers_caught_up
from .topics import CRTK_VERSION, LATCHED_COMMANDS, LatchedCommandReader, fill_pose, msg_class, on_new_reader, qos


class CrtkArmTopics:
    def __init__(self, node, arm, namespace: str, specs: dict, published, handlers: dict, *, frame: str):
        self.node, self.arm, self.ns, self.specs = node, arm, namespace, specs
        self.frame = frame  # operating_state's frame_id
        again = on_new_reader(lambda: self.emit([("operating_state", arm.report())]))
        self.pubs = {name: node.create_publisher(msg_class(specs[name]), f"{namespace}/{name}", qos(specs[name]),
                                                 **({"event_callbacks": again} if name == "operating_state" else {}))
                     for name in published}
        self.subs = [node.create_subscription(msg_class(specs[name]), f"{namespace}/{name}",
                                              lambda m, h=handler, n=name: self._on(n, h, m), qos(specs[name]))
                     for name, handler in handlers.items() if name not in LATCHED_COMMANDS]
        self.subs += [LatchedCommandReader(node, msg_class(specs[name]), f"{namespace}/{name}", qos(specs[name]),
                                           lambda m, info, latched, h=handler, n=name: self._on(n, h, m))
                      for name, handler in handlers.items() if name in LATCHED_COMMANDS]  # crtk latches them
        self.hold = HomedHold()  # one arm: key None
        self.services = [node.create_service(TriggerOperatingState, f"{namespace}/operating_state", self._srv_state),
                         node.create_service(Trigger, f"{namespace}/crtk_version", self._srv_version)]
        self.emit([("operating_state", arm.report())])

    def _out(self, name, msg):
        """Publishes on the arm's topic `name` and records it when the node records."""
        self.pubs[name].publish(msg)
        if self.node.recorder is not None:
            self.node._record(f"{self.ns}/{name}", msg)

    def latched(self) -> list:
        """(topic, message) a new recording opens with: the arm's state."""
        return [(f"{self.ns}/operating_state", self._state_msg(self.arm.report()))]

    def _on(self, name, handler, msg):
        if self.node.recorder is not None:  # what the arm was told, as the PSMs' commands are kept
            self.node._record(f"{self.ns}/{name}", msg)
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
        """The arm's (topic, value) events as messages: operating_state, bools (goal_reached),
        text (errors and warnings prefixed with the arm's name, and logged)."""
        for topic, value in (item for event in events for item in self.hold.admit(None, *event)):
            if topic == "operating_state":
                msg = self._state_msg(value)
            elif isinstance(value, bool):
                msg = Bool(data=value)
            else:
                msg = String(data=f"{self.arm.name}: {value}" if topic in ("error", "warning") else str(value))
                if topic in ("error", "warning"):
                    self.node.get_logger().warning(msg.data, throttle_duration_sec=1.0)
            self._out(topic, msg)

    def check_hold(self):
        """Before the tick's samples: whether the state topics' readers will get them."""
        self.hold.check(lambda _: readers_caught_up(self.pubs, self.pubs["operating_state"]))

    def release_held(self):
        """After the tick's samples: a held answer to `home` whose wait is over."""
        for _, topic, value in self.hold.due(self.node.arms.period_ns):
            self._out(topic, self._state_msg(value))

    def joint_state(self, name, stamp, names, position, velocity):
        m = msg_class(self.specs[name])()
        m.header.stamp = stamp
        m.name = list(names)
        m.position, m.velocity, m.effort = array("d", position), array("d", velocity), array("d", [0.0] * len(names))
        self._out(name, m)

    def poses(self, stamp, items):
        """PoseStamped on each (topic, frame_id, 4x4) of `items`, converted together."""
        p7 = matrix_to_pose7(torch.as_tensor(np.stack([T for _, _, T in items]))).numpy()
        for (name, frame, _), p in zip(items, p7):
            m = msg_class(self.specs[name])()
            m.header.stamp, m.header.frame_id = stamp, frame
            fill_pose(m.pose, p)
            self._out(name, m)

    def _srv_state(self, request, response):
        response.operating_state = self._state_msg(self.arm.report())
        return response

    def _srv_version(self, request, response):
        response.success, response.message = True, CRTK_VERSION
        return response


__all__ = ["CrtkArmTopics"]
