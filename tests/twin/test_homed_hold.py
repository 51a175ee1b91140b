"""The operating_state that answers `home` waits for the arm's state readers (homed_hold.py), over
DDS: a twin in a subprocess, paused and stepped tick by tick by a client in a context (a DDS
participant) of its own, which paces each step on the twin's /clock sample of it.

- A client that reads every state topic, whose setpoint_cp reader comes late (after the arm has
  finished homing: a reader that discovery has not matched yet), is told "homed" only after a
  setpoint_cp sample has reached it, and before the hold's bound (released by its readers).
- A client that reads operating_state alone is told "homed" when the bound is over, LIMIT_NS of
  simulated time after the homing ended, while the twin goes on ticking.
"""
from __future__ import annotations

import pytest
from twin_fixtures import OwnContextClient

pytestmark = pytest.mark.ros

HANG = 120.0  # s: a safety limit on each wait, only to catch a hang
STATE = ("measured_js", "setpoint_js", "measured_cp")  # setpoint_cp: the late one
PERIOD_NS = 10_000_000  # the default scene's 100 Hz


class Client(OwnContextClient):
    """Reads /PSM1/operating_state, /PSM1/status, /clock (and `state` topics), sends state commands,
    pauses and steps the twin; every arrival in one ordered log."""

    def __init__(self, domain: int, state=()):
        from crtk_msgs.msg import OperatingState, StringStamped
        from rclpy.qos import DurabilityPolicy, QoSProfile
        from rosgraph_msgs.msg import Clock
        from simulation_interfaces import srv
        from simulation_interfaces.msg import Result
        from std_msgs.msg import String

        from cressim_ros.topics import CLOCK_QOS, TOPICS_BY_NAME, msg_class, qos

        self.StringStamped, self.Result = StringStamped, Result
        self.msg_class, self.qos, self.specs = msg_class, qos, TOPICS_BY_NAME
        super().__init__(domain, "homing_client")
        self.log = []  # (topic, value) in arrival order
        self.clocks = 0
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)  # as crtk's state_command
        self.command_pub = self.node.create_publisher(StringStamped, "/PSM1/state_command", latched)
        self.node.create_subscription(OperatingState, "/PSM1/operating_state",
                                      lambda m: self._arrived("operating_state", (m.state, m.is_homed, m.is_busy)),
                                      qos(TOPICS_BY_NAME["operating_state"]))
        self.node.create_subscription(String, "/PSM1/status", lambda m: self._arrived("status", m.data),
                                      qos(TOPICS_BY_NAME["status"]))
        self.node.create_subscription(Clock, "/clock", self._on_clock, CLOCK_QOS)
        for topic in state:
            self.read(topic)
        self.services = {name: self.node.create_client(kind, f"/{name}")
                         for name, kind in (("set_simulation_state", srv.SetSimulationState),
                                            ("step_simulation", srv.StepSimulation))}
        self.start()

    def _arrived(self, topic, value):
        with self.cv:
            self.log.append((topic, value))
            self.cv.notify_all()

    def _on_clock(self, msg):
        with self.cv:
            self.clocks += 1
            self.cv.notify_all()

    def read(self, topic):
        spec = self.specs[topic]
        return self.node.create_subscription(self.msg_class(spec), f"/PSM1/{topic}",
                                             lambda m, t=topic: self._arrived(t, None), self.qos(spec))

    def wait(self, predicate, what, timeout=HANG):
        with self.cv:
            assert self.cv.wait_for(predicate, timeout), f"{what}: {self.log[-20:]}"

    def seen(self, topic, value=None) -> int:
        return sum(1 for t, v in self.log if t == topic and (value is None or v == value))

    def homed_told(self) -> bool:
        return self.seen("operating_state", ("ENABLED", True, False)) > 0

    def call(self, name, **fields):
        client = self.services[name]
        assert client.wait_for_service(timeout_sec=HANG), name
        request = client.srv_type.Request()
        for k, v in fields.items():
            setattr(request, k, v)
        response = client.call(request, timeout_sec=HANG)
        assert response is not None, f"{name}: no response"
        assert response.result.result == self.Result.RESULT_OK, (name, response.result.error_message)
        return response

    def pause(self):
        from simulation_interfaces.msg import SimulationState

        self.call("set_simulation_state", state=SimulationState(state=SimulationState.STATE_PAUSED))

    def step(self):
        """One tick, and its /clock sample here (what the tick published before it has come too)."""
        with self.cv:
            count = self.clocks
        self.call("step_simulation", steps=1)
        self.wait(lambda: self.clocks > count, "the step's /clock")

    def command(self, text):
        msg = self.StringStamped(string=text)
        msg.header.stamp = self.node.get_clock().now().to_msg()
        self.command_pub.publish(msg)

    def home(self):
        """enable and home, answered while the twin is paused (commands need no tick); steps until
        the twin says on `status` that homing is done; the number of steps since."""
        self.wait(lambda: self.seen("operating_state") > 0, "the twin's state for our reader")
        self.command("enable")
        self.wait(lambda: self.seen("operating_state", ("ENABLED", False, False)) > 0, "enabled")
        self.command("home")
        self.wait(lambda: self.seen("operating_state", ("ENABLED", False, True)) > 0, "homing under way")
        for _ in range(1000):
            if self.seen("status", "PSM1: homed"):
                return
            self.step()
        raise AssertionError(f"homing never finished: {self.log[-20:]}")


@pytest.fixture
def paused_twin(start_twin, ros_domain_id):
    """client(state=(...)) -> a Client of a twin (the default scene, joints, poses and /clock)
    that it has paused."""
    pytest.importorskip("simulation_interfaces.srv", reason="ros_ws's simulation_interfaces is not built")
    start_twin(ros_domain_id, "sensors:=[joints, cartesian, clock]")
    clients = []

    def make(state=()):
        client = Client(ros_domain_id, state)
        clients.append(client)
        client.pause()
        return client

    yield make
    for client in clients:
        client.close()


def test_a_late_setpoint_cp_reader_gets_a_sample_before_homed(paused_twin):
    from cressim_ros.homed_hold import LIMIT_NS

    client = paused_twin(state=STATE)
    client.home()
    # its setpoint_cp reader does not exist: the answer is held though the twin ticks on
    for _ in range(5):
        client.step()
    assert not client.homed_told(), client.log[-20:]
    client.read("setpoint_cp")  # the late reader: the twin matches it when discovery finds it
    steps = 5
    while not client.homed_told():
        before = client.seen("setpoint_cp")
        client.step()
        steps += 1
        if before == 0:  # give discovery time to match it between two ticks (nothing else waits on it)
            with client.cv:
                client.cv.wait_for(lambda: client.seen("setpoint_cp") > 0 or client.homed_told(), 0.1)
    with client.cv:
        first_homed = client.log.index(("operating_state", ("ENABLED", True, False)))
        samples = [t for t, _ in client.log[:first_homed]]
    assert "setpoint_cp" in samples and all(t in samples for t in STATE), client.log[-20:]
    assert steps < LIMIT_NS // PERIOD_NS  # released by its readers, not by the bound


def test_a_client_reading_operating_state_alone_is_told_homed_at_the_bound(paused_twin):
    from cressim_ros.homed_hold import LIMIT_NS

    client = paused_twin()
    client.home()
    steps = 0
    while not client.homed_told():
        assert steps <= 2 * LIMIT_NS // PERIOD_NS, f"never told homed: {client.log[-20:]}"
        client.step()
        steps += 1
    # held for the bound's ticks after the one that ended the homing, give or take the one tick
    # by which `status` or the answer may come after the step's /clock sample
    assert LIMIT_NS // PERIOD_NS - 1 <= steps <= LIMIT_NS // PERIOD_NS + 1, steps
