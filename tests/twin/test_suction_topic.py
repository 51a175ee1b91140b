"""The suction valve over ROS (in this process, ticked by hand): a client opens the psm_suction
tool's valve on /PSM1/suction/servo_jp over DDS, and /PSM1/suction/measured_js reports the valve
open and the blood it removes; a bad valve value is refused on /PSM1/error."""
import pytest

pytestmark = pytest.mark.ros


def test_a_client_opens_the_suction_valve_over_dds(make_node):
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from sensor_msgs.msg import JointState
    from std_msgs.msg import String

    from cressim.twin import JointCommand

    node = make_node(scene="psm_suction.yaml", sensors=["joints", "clock"])
    node.timer.cancel()  # ticked here
    arms = node.arms
    arms.state_command(0, "enable")
    arms.state_command(0, "home")
    while arms.states[0].is_busy:
        node._tick()
    arms.move_jp(0, JointCommand(position=[0.0, 0.0, 0.1385, 0.0, 0.0, 0.0]))  # the tube's end in the pool
    while arms.states[0].is_busy:
        node._tick()
    client = rclpy.create_node("suction_client", context=node.context)
    valve = client.create_publisher(JointState, "/PSM1/suction/servo_jp", 1)
    measured, errors = [], []
    client.create_subscription(JointState, "/PSM1/suction/measured_js", measured.append, 100)
    client.create_subscription(String, "/PSM1/error", errors.append, 100)
    executor = SingleThreadedExecutor(context=node.context)
    executor.add_node(node)
    executor.add_node(client)
    try:
        def until(done, what):
            for _ in range(300):
                if done():
                    return
                node._tick()
                executor.spin_once(timeout_sec=0.02)
            raise AssertionError(what)

        until(lambda: measured and valve.get_subscription_count() > 0, "no suction/measured_js")
        assert measured[-1].name == ["suction"] and measured[-1].position[0] == 0.0
        valve.publish(JointState(position=[2.0]))
        until(lambda: errors, "a valve of 2 was not refused")
        assert "suction/servo_jp refused" in errors[-1].data
        valve.publish(JointState(name=["suction"], position=[1.0]))
        until(lambda: measured[-1].position[0] == 1.0 and measured[-1].effort[0] > 0, "no blood removed")
    finally:
        executor.shutdown()
        client.destroy_node()
