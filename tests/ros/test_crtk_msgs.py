"""crtk_msgs over real DDS: two rclpy nodes (separate contexts, i.e. separate DDS participants) in
this process, and a node in a subprocess. Run under `source ros_ws/env.sh` (see conftest.py)."""
import os
import subprocess
import sys
import time

import pytest

rclpy = pytest.importorskip("rclpy", reason="rclpy not importable: ROS 2 wheels not installed "
                            "(ros_ws/build.sh, then source ros_ws/env.sh)")
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy  # noqa: E402

EVENT_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.TRANSIENT_LOCAL)
COMMAND_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.VOLATILE)
TIMEOUT = 15.0
PEER = os.path.join(os.path.dirname(os.path.abspath(__file__)), "crtk_peer.py")


@pytest.fixture
def crtk(crtk_env):
    from crtk_msgs import msg, srv
    return msg, srv


class Participant:
    """An rclpy context + node + executor of its own (its own DDS participant)."""

    def __init__(self, name, domain_id):
        self.context = rclpy.Context()
        rclpy.init(context=self.context, domain_id=domain_id)
        self.node = rclpy.create_node(name, context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)

    def close(self):
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)


@pytest.fixture
def participants(ros_domain_id):
    made = []

    def make(name):
        p = Participant(name, ros_domain_id)
        made.append(p)
        return p

    yield make
    for p in reversed(made):
        p.close()


def spin_until(done, participants, timeout=TIMEOUT, every=None):
    """Spin all participants until done() is true; call every() on each round (e.g. to publish)."""
    deadline = time.monotonic() + timeout
    while not done():
        if time.monotonic() > deadline:
            return False
        if every is not None:
            every()
        for p in participants:
            p.executor.spin_once(timeout_sec=0.02)
    return True


def stamp_ns(stamp):
    return stamp.sec * 1_000_000_000 + stamp.nanosec


def test_operating_state_and_string_stamped_between_two_nodes(crtk, participants):
    msg, _ = crtk
    a, b = participants("twin"), participants("client")
    state_pub = a.node.create_publisher(msg.OperatingState, "/PSM1/operating_state", EVENT_QOS)
    cmd_pub = a.node.create_publisher(msg.StringStamped, "/PSM1/state_command", COMMAND_QOS)
    cart_pub = a.node.create_publisher(msg.CartesianState, "/PSM1/measured_cs", EVENT_QOS)
    got = {"state": [], "cmd": [], "cart": []}
    b.node.create_subscription(msg.OperatingState, "/PSM1/operating_state",
                               got["state"].append, EVENT_QOS)
    b.node.create_subscription(msg.StringStamped, "/PSM1/state_command",
                               got["cmd"].append, COMMAND_QOS)
    b.node.create_subscription(msg.CartesianState, "/PSM1/measured_cs",
                               got["cart"].append, EVENT_QOS)

    sent_state = msg.OperatingState(state=msg.OperatingState.STATE_ENABLED, is_homed=True,
                                    is_busy=False)
    sent_state.header.stamp = a.node.get_clock().now().to_msg()
    sent_state.header.frame_id = "PSM1"
    state_pub.publish(sent_state)  # transient local: reaches b even if published before matching

    sent_cart = msg.CartesianState()
    sent_cart.header.stamp = sent_state.header.stamp
    sent_cart.header.frame_id = "PSM1_base"
    sent_cart.pose.position.x, sent_cart.pose.position.y, sent_cart.pose.position.z = .1, -.2, .3
    sent_cart.pose.orientation.w = 1.0
    sent_cart.pose_is_valid.data = True
    sent_cart.twist.angular.z = 0.5
    sent_cart.twist_is_valid.data = True
    sent_cart.wrench_is_valid.data = False
    cart_pub.publish(sent_cart)

    sent_cmd = msg.StringStamped(string="home")
    sent_cmd.header.stamp = a.node.get_clock().now().to_msg()
    sent_cmd.header.frame_id = "console"
    # volatile, depth 1 (as the dVRK's state_command): publish until the subscriber has matched
    assert spin_until(lambda: got["state"] and got["cmd"] and got["cart"], [a, b],
                      every=lambda: cmd_pub.publish(sent_cmd)), \
        f"nothing received over DDS in {TIMEOUT} s: {[(k, len(v)) for k, v in got.items()]}"

    rs = got["state"][0]
    assert (rs.state, rs.is_homed, rs.is_busy) == ("ENABLED", True, False)
    assert rs.header.frame_id == "PSM1"
    assert stamp_ns(rs.header.stamp) == stamp_ns(sent_state.header.stamp) > 0
    assert rs == sent_state

    rc = got["cmd"][0]
    assert rc.string == "home" and rc.header.frame_id == "console"
    assert stamp_ns(rc.header.stamp) == stamp_ns(sent_cmd.header.stamp) > 0

    cart = got["cart"][0]
    assert cart == sent_cart
    assert (cart.pose.position.x, cart.pose.position.y, cart.pose.position.z) == (.1, -.2, .3)
    assert cart.pose_is_valid.data and cart.twist_is_valid.data and not cart.wrench_is_valid.data


def test_trigger_operating_state_service(crtk, participants):
    msg, srv = crtk
    a, b = participants("twin"), participants("client")
    calls = []

    def serve(request, response):
        calls.append(request)
        response.operating_state.header.stamp = a.node.get_clock().now().to_msg()
        response.operating_state.header.frame_id = "PSM1"
        response.operating_state.state = msg.OperatingState.STATE_PAUSED
        response.operating_state.is_homed = True
        response.operating_state.is_busy = True
        return response

    a.node.create_service(srv.TriggerOperatingState, "/PSM1/operating_state", serve)
    client = b.node.create_client(srv.TriggerOperatingState, "/PSM1/operating_state")
    assert spin_until(client.service_is_ready, [a, b]), "service not discovered"
    future = client.call_async(srv.TriggerOperatingState.Request())
    assert spin_until(future.done, [a, b]), "no service response"
    result = future.result().operating_state
    assert len(calls) == 1
    assert (result.state, result.is_homed, result.is_busy) == ("PAUSED", True, True)
    assert result.header.frame_id == "PSM1" and stamp_ns(result.header.stamp) > 0


def test_kinematics_services_types(crtk):
    """The kinematics query services carry the fields the twin fills in."""
    _, srv = crtk
    fk = srv.QueryForwardKinematics.Request(jp=[0.1, 0.2, 0.12, 0.0, 0.0, 0.0])
    fk.cp.orientation.w = 1.0
    assert list(fk.jp) == [0.1, 0.2, 0.12, 0.0, 0.0, 0.0]
    r = srv.QueryForwardKinematics.Response(result=True, message="ok")
    assert r.result and r.message == "ok" and r.cp.orientation.w == 1.0
    ik = srv.QueryInverseKinematics.Response(jp=[1.0, 2.0], result=False, message="unreachable")
    assert list(ik.jp) == [1.0, 2.0] and not ik.result
    assert list(srv.QueryInverseKinematics.Request().jp) == []


def test_crtk_round_trip_with_node_in_subprocess(crtk, participants, ros_domain_id):
    msg, srv = crtk
    peer = subprocess.Popen([sys.executable, PEER, "/PSM1"], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            env=dict(os.environ))
    try:
        assert peer.stdout.readline().strip() == "READY", "peer node did not start"
        b = participants("client")
        cmd_pub = b.node.create_publisher(msg.StringStamped, "/PSM1/state_command", COMMAND_QOS)
        states, echoes = [], []
        b.node.create_subscription(msg.OperatingState, "/PSM1/operating_state", states.append,
                                   EVENT_QOS)
        b.node.create_subscription(msg.StringStamped, "/PSM1/state_command_echo", echoes.append,
                                   EVENT_QOS)
        client = b.node.create_client(srv.TriggerOperatingState, "/PSM1/operating_state")

        def command(text):
            c = msg.StringStamped(string=text)
            c.header.stamp = b.node.get_clock().now().to_msg()
            c.header.frame_id = "test"
            return c

        enable = command("enable")
        assert spin_until(lambda: any(e.string == "enable" for e in echoes), [b],
                          every=lambda: cmd_pub.publish(enable)), "peer did not hear 'enable'"
        echo = next(e for e in echoes if e.string == "enable")
        assert echo == enable
        home = command("home")
        assert spin_until(lambda: any(s.is_homed for s in states), [b],
                          every=lambda: cmd_pub.publish(home)), "no homed OperatingState"
        last = states[-1]
        assert (last.state, last.is_homed, last.is_busy) == ("ENABLED", True, False)
        assert last.header.frame_id == "PSM1" and stamp_ns(last.header.stamp) > 0

        assert spin_until(client.service_is_ready, [b]), "peer service not discovered"
        future = client.call_async(srv.TriggerOperatingState.Request())
        assert spin_until(future.done, [b]), "no service response from peer"
        r = future.result().operating_state
        assert (r.state, r.is_homed, r.is_busy) == ("ENABLED", True, False)
        assert stamp_ns(r.header.stamp) >= stamp_ns(last.header.stamp) > 0
    finally:
        peer.stdin.close()
        try:
            peer.wait(timeout=10)
        except subprocess.TimeoutExpired:
            peer.kill()
            peer.wait()
    out = peer.stdout.read()
    peer.stdout.close()
    assert peer.returncode == 0, f"peer exited {peer.returncode}:\n{out}"
