"""The rest of the dVRK PSM and console interface over DDS (the node in this process, spun with
a client node): console power and home for every arm, teleop answers, trajectory_j ratios
published, the tool and effort-mode settings kept, a stale command refused at its arrival."""
import time

import pytest

pytestmark = pytest.mark.ros


@pytest.fixture
def wired(make_node):
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    node = make_node(num_envs=2, camera_rate=1.0)
    client = rclpy.create_node("interface_client", context=node.context)
    executor = SingleThreadedExecutor(context=node.context)
    executor.add_node(node)
    executor.add_node(client)

    def spin_until(predicate, what, spins=3000):
        for _ in range(spins):
            if predicate():
                return
            executor.spin_once(timeout_sec=0.01)
        raise AssertionError(f"timed out waiting for {what}")

    yield node, client, spin_until
    executor.shutdown()
    client.destroy_node()


def _latched():
    from rclpy.qos import DurabilityPolicy, QoSProfile

    return QoSProfile(depth=10, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def test_console_power_and_home_reach_every_arm(wired):
    from crtk_msgs.msg import OperatingState
    from std_msgs.msg import Bool, Empty, Float64, String

    node, client, spin_until = wired
    states = {0: [], 1: []}
    for env in (0, 1):
        client.create_subscription(OperatingState, f"/env{env}/PSM1/operating_state", states[env].append, _latched())
    console = {name: client.create_publisher(Empty, f"/console/{name}", 10) for name in ("power_on", "home")}
    power_off = client.create_publisher(Empty, "/system/power_off", 10)  # dVRK 2.3's name
    spin_until(lambda: all(p.get_subscription_count() for p in console.values()), "console subscriptions")
    console["power_on"].publish(Empty())
    spin_until(lambda: all(s and s[-1].state == "ENABLED" for s in states.values()), "ENABLED")
    console["home"].publish(Empty())
    spin_until(lambda: all(s[-1].is_homed and not s[-1].is_busy for s in states.values()), "homed")
    assert all(any(m.is_busy for m in s) for s in states.values()), "homing takes time (is_busy)"
    spin_until(lambda: power_off.get_subscription_count(), "system subscription")
    power_off.publish(Empty())
    spin_until(lambda: all(s[-1].state == "DISABLED" for s in states.values()), "DISABLED")

    enabled, scale, selected = [], [], []
    client.create_subscription(Bool, "/console/teleop/enabled", enabled.append, _latched())
    client.create_subscription(Float64, "/console/teleop/scale", scale.append, _latched())
    client.create_subscription(String, "/console/teleop/selected", selected.append, _latched())
    teleop = client.create_publisher(Bool, "/console/teleop/enable", 10)
    set_scale = client.create_publisher(Float64, "/console/teleop/set_scale", 10)
    select = client.create_publisher(String, "/console/teleop/select", 10)
    spin_until(lambda: teleop.get_subscription_count() and set_scale.get_subscription_count()
               and select.get_subscription_count(), "teleop subscriptions")
    teleop.publish(Bool(data=True))
    set_scale.publish(Float64(data=0.5))
    select.publish(String(data="MTMR_PSM1"))
    spin_until(lambda: len(enabled) >= 2 and scale and scale[-1].data == 0.5 and selected, "teleop answers")
    assert not enabled[-1].data, "no MTM: teleoperation stays off"
    assert selected[-1].data == "MTMR_PSM1"


def test_ratio_tool_and_settings(wired):
    from std_msgs.msg import Bool, Float64, String

    node, client, spin_until = wired
    ratio, ratio_v, tool, status, warnings = [], [], [], [], []
    ns = "/env1/PSM1"
    client.create_subscription(Float64, f"{ns}/trajectory_j/ratio", ratio.append, 10)
    client.create_subscription(Float64, f"{ns}/trajectory_j/ratio_v", ratio_v.append, _latched())
    client.create_subscription(String, f"{ns}/tool_type", tool.append, _latched())
    client.create_subscription(String, f"{ns}/status", status.append, _latched())
    client.create_subscription(String, f"{ns}/warning", warnings.append, _latched())
    spin_until(lambda: tool and ratio_v, "latched tool_type and ratio_v")
    assert tool[-1].data == "LARGE_NEEDLE_DRIVER:400006" and ratio_v[-1].data == 1.0

    set_ratio_v = client.create_publisher(Float64, f"{ns}/trajectory_j/set_ratio_v", 10)
    gravity = client.create_publisher(Bool, f"{ns}/use_gravity_compensation", 10)
    set_tool = client.create_publisher(String, f"{ns}/set_tool_type", 10)
    spin_until(lambda: all(p.get_subscription_count() for p in (set_ratio_v, gravity, set_tool)), "subscriptions")
    set_ratio_v.publish(Float64(data=0.5))
    spin_until(lambda: ratio_v[-1].data == 0.5 and ratio and ratio[-1].data == 0.5, "ratio_v 0.5")
    assert float(node.arms.ratio_v[1]) == 0.5 and float(node.arms.ratio_v[0]) == 1.0  # env 1 only
    gravity.publish(Bool(data=False))
    spin_until(lambda: any("use_gravity_compensation off" in m.data for m in status), "status")
    assert node.arms.flags[1]["use_gravity_compensation"] is False
    set_tool.publish(String(data="PROGRASP_FORCEPS:420093"))
    spin_until(lambda: any("set_tool_type refused" in m.data for m in warnings), "set_tool_type warning")


def test_stale_command_is_refused_at_arrival(wired):
    """A state_command stamped 3 s before it arrives is stale; one stamped now is not, however
    long the node takes to get to it (the age is taken at arrival)."""
    from builtin_interfaces.msg import Time
    from crtk_msgs.msg import StringStamped
    from std_msgs.msg import String

    node, client, spin_until = wired
    errors = []
    client.create_subscription(String, "/env0/PSM1/error", errors.append, _latched())
    pub = client.create_publisher(StringStamped, "/env0/PSM1/state_command", 10)
    spin_until(lambda: pub.get_subscription_count(), "state_command subscription")
    old = time.time_ns() - 3_000_000_000
    msg = StringStamped(string="enable")
    msg.header.stamp = Time(sec=old // 10**9, nanosec=old % 10**9)
    pub.publish(msg)
    spin_until(lambda: errors, "a refusal")
    assert "stale command" in errors[-1].data and node.arms.states[0].state == "DISABLED"
    now = time.time_ns()
    msg.header.stamp = Time(sec=now // 10**9, nanosec=now % 10**9)
    pub.publish(msg)
    time.sleep(1.5)  # the node is busy elsewhere for longer than the limit: still fresh at arrival
    spin_until(lambda: node.arms.states[0].state == "ENABLED", "enable")


def test_client_writers_meet_no_incompatible_qos_and_a_latched_command_outlives_discovery(make_node, ros_domain_id,
                                                                                          capfd):
    """crtk's state_command writer is latched (transient local, depth 10): its `enable`, sent
    before the twin exists (seconds before: older than the stale limit), still enables the arm;
    then, the writer caught up with (its `home` came through both of the twin's readers), every
    writer of the dVRK's clients with their real QoS (crtk's volatile depth 10, dvrk's latched
    settings, dvrk.system's depth 1, a volatile state_command as `ros2 topic pub` sends it)
    finds a peer and no incompatible QoS, on either side."""
    import rclpy
    from rclpy.context import Context
    from rclpy.event_handler import PublisherEventCallbacks
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import DurabilityPolicy, QoSProfile
    from crtk_msgs.msg import StringStamped

    from cressim_ros.topics import TOPICS_BY_NAME, arm_topics, msg_class

    context = Context()
    rclpy.init(context=context, domain_id=ros_domain_id)
    client = rclpy.create_node("qos_client", context=context)
    incompatible = []

    def writer(topic, msg_type, profile):
        events = PublisherEventCallbacks(incompatible_qos=lambda status: incompatible.append((topic, status)))
        return client.create_publisher(msg_type, topic, profile, event_callbacks=events)

    def command(pub, text):
        msg = StringStamped(string=text)
        msg.header.stamp = client.get_clock().now().to_msg()
        pub.publish(msg)

    try:
        latched = QoSProfile(depth=10, durability=DurabilityPolicy.TRANSIENT_LOCAL)  # crtk's
        crtk = writer("/PSM1/state_command", StringStamped, latched)
        command(crtk, "enable")
        node = make_node()
        executors = [SingleThreadedExecutor(context=c) for c in (node.context, context)]
        executors[0].add_node(node)
        executors[1].add_node(client)

        def spin_until(predicate, what, spins=3000):
            for _ in range(spins):
                if predicate():
                    return
                for executor in executors:
                    executor.spin_once(timeout_sec=0.01)
            raise AssertionError(f"timed out waiting for {what}")

        spin_until(lambda: node.arms.states[0].state == "ENABLED", "the latched enable")
        command(crtk, "home")
        readers = [r for r in node._latched_readers if r.topic == "/PSM1/state_command"]
        spin_until(lambda: node.arms.states[0].is_homed and readers[0].catch_up is None, "homed, caught up")
        writers = [writer(f"/PSM1/{t.name}", msg_class(t), QoSProfile(depth=10)) for t in arm_topics("command")]
        writers += [writer(f"/PSM1/{name}", msg_class(TOPICS_BY_NAME[name]), QoSProfile(
            depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL))
            for name in ("body/set_cf_orientation_absolute", "use_gravity_compensation", "trajectory_j/set_ratio")]
        writers += [writer(f"/system/{name}", msg_class(TOPICS_BY_NAME[f"/console/{name}"]), QoSProfile(depth=1))
                    for name in ("power_off", "power_on", "home", "set_volume", "beep", "string_to_speech")]
        spin_until(lambda: all(w.get_subscription_count() for w in writers), "a peer for every writer")
        volatile = writers[0]  # arm_topics("command") starts with state_command
        assert volatile.topic_name == "/PSM1/state_command"
        command(volatile, "disable")
        spin_until(lambda: node.arms.states[0].state == "DISABLED", "a volatile writer's disable")
    finally:
        client.destroy_node()
        rclpy.try_shutdown(context=context)
    assert not incompatible, incompatible
    err = capfd.readouterr().err
    assert "incompatible QoS" not in err, err[-3000:]
