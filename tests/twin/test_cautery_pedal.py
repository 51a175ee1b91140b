"""The coagulation pedal over ROS (in this process, ticked by hand): a client presses
/footpedals/coag (sensor_msgs/Joy, as the dVRK console publishes it) over DDS while the needle
driver rests on the liver of scenes/psm_cautery.yaml, and the tissue at the jaws coagulates;
released, the heating stops."""
import numpy as np
import pytest

pytestmark = pytest.mark.ros

TOP = np.array([0.0, 0.0, 0.1615])


def test_a_client_presses_the_coag_pedal_over_dds(make_node):
    from sensor_msgs.msg import Joy

    from arm_moves import jaws_at
    from hand_ticked import client_beside, homed

    node = make_node(scene="psm_cautery.yaml", sensors=["joints", "clock"])
    arms = homed(node)
    jaws_at(arms, 0.0, jaws=[0.0], point=TOP)  # the jaws on the liver (the arm ticked without publishing)
    engine = arms.bodies.engine
    with client_beside(node, "pedal_client") as (client, until):
        pedal = client.create_publisher(Joy, "/footpedals/coag", 10)
        until(lambda: pedal.get_subscription_count() > 0, "the twin does not listen on /footpedals/coag")
        pedal.publish(Joy(buttons=[1]))
        until(lambda: bool(arms.instrument("cautery").pedal[0]), "the press did not arrive")
        until(lambda: (engine.buffer("particles.damage").read() > 1.0).sum() >= 2, "the liver did not coagulate",
              ticks=400)
        pedal.publish(Joy(buttons=[0]))
        until(lambda: not arms.instrument("cautery").pedal[0], "the release did not arrive")
        node._tick()
        peak = engine.buffer("particles.temperatures").read().max()
        for _ in range(20):
            node._tick()
        assert engine.buffer("particles.temperatures").read().max() < peak  # no more heat in
