"""The coagulation pedal over ROS (in this process, ticked by hand): a client presses
/footpedals/coag (sensor_msgs/Joy, as the dVRK console publishes it) over DDS while the needle
driver rests on the liver of scenes/psm_cautery.yaml, and the tissue at the jaws coagulates;
released, the heating stops."""
import numpy as np
import pytest

pytestmark = pytest.mark.ros

TOP = np.array([0.0, 0.0, 0.1615])


def test_a_client_presses_the_coag_pedal_over_dds(make_node):
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from sensor_msgs.msg import Joy

    from arm_moves import jaws_at

    node = make_node(scene="psm_cautery.yaml", sensors=["joints", "clock"])
    node.timer.cancel()  # ticked here
    arms = node.arms
    arms.state_command(0, "enable")
    arms.state_command(0, "home")
    while arms.states[0].is_busy:
        node._tick()
    jaws_at(arms, 0.0, jaws=[0.0], point=TOP)  # the jaws on the liver (the arm ticked without publishing)
    client = rclpy.create_node("pedal_client", context=node.context)
    pedal = client.create_publisher(Joy, "/footpedals/coag", 10)
    executor = SingleThreadedExecutor(context=node.context)
    executor.add_node(node)
    executor.add_node(client)
    engine = arms.bodies.engine
    try:
        def until(done, what, ticks=400):
            for _ in range(ticks):
                if done():
                    return
                node._tick()
                executor.spin_once(timeout_sec=0.02)
            raise AssertionError(what)

        until(lambda: pedal.get_subscription_count() > 0, "the twin does not listen on /footpedals/coag")
        pedal.publish(Joy(buttons=[1]))
        until(lambda: bool(arms.coag_pedal[0]), "the press did not arrive")
        until(lambda: (engine.buffer("particles.damage").read() > 1.0).sum() >= 2, "the liver did not coagulate")
        pedal.publish(Joy(buttons=[0]))
        until(lambda: not arms.coag_pedal[0], "the release did not arrive")
        node._tick()
        peak = engine.buffer("particles.temperatures").read().max()
        for _ in range(20):
            node._tick()
        assert engine.buffer("particles.temperatures").read().max() < peak  # no more heat in
    finally:
        executor.shutdown()
        client.destroy_node()
