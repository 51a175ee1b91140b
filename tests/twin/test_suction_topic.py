"""The suction valve over ROS (in this process, ticked by hand): a client opens the psm_suction
tool's valve on /PSM1/suction/servo_jp over DDS, and /PSM1/suction/measured_js reports the valve
open and the blood it removes; a bad valve value is refused on /PSM1/error."""
import pytest

pytestmark = pytest.mark.ros


def test_a_client_opens_the_suction_valve_over_dds(make_node):
    from sensor_msgs.msg import JointState
    from std_msgs.msg import String

    from cressim.twin import JointCommand
    from hand_ticked import client_beside, homed, settled

    node = make_node(scene="psm_suction.yaml", sensors=["joints", "clock"])
    arms = homed(node)
    arms.move_jp(0, JointCommand(position=[0.0, 0.0, 0.1385, 0.0, 0.0, 0.0]))  # the tube's end in the pool
    settled(node)
    with client_beside(node, "suction_client") as (client, until):
        valve = client.create_publisher(JointState, "/PSM1/suction/servo_jp", 1)
        measured, errors = [], []
        client.create_subscription(JointState, "/PSM1/suction/measured_js", measured.append, 100)
        client.create_subscription(String, "/PSM1/error", errors.append, 100)
        until(lambda: measured and valve.get_subscription_count() > 0, "no suction/measured_js")
        assert measured[-1].name == ["suction"] and measured[-1].position[0] == 0.0
        valve.publish(JointState(position=[2.0]))
        until(lambda: errors, "a valve of 2 was not refused")
        assert "suction/servo_jp refused" in errors[-1].data
        valve.publish(JointState(name=["suction"], position=[1.0]))
        until(lambda: measured[-1].position[0] == 1.0 and measured[-1].effort[0] > 0, "no blood removed")
