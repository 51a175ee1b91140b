"""The console without ROS (cressim.twin.mtm): the MTM follows the operator's hand and its wrist
commands, the scripted operator interpolates its keyframes, the scene file's `cart.operator`."""
import math

import numpy as np
import pytest
from types import SimpleNamespace

from cressim.twin import parse_scene
from cressim.twin.mtm import Keyframe, MtmArm, Operator, ScriptedOperator
from cressim.twin_scene_file import SceneError


def _pose(position, xyzw):
    """What a geometry_msgs/Pose carries (no ROS here)."""
    x, y, z, w = xyzw
    return SimpleNamespace(position=SimpleNamespace(x=position[0], y=position[1], z=position[2]),
                           orientation=SimpleNamespace(x=x, y=y, z=z, w=w))


def test_mtm_follows_the_hand_and_its_wrist():
    mtm, op = MtmArm("MTMR"), Operator(["MTMR"])
    assert mtm.move_cp(_pose((0, 0, 0), (0, 0, 0, 1)))[0][0] == "error"  # not enabled, not homed
    for command in ("enable", "home"):
        mtm.state_command(command)
    assert mtm.report() == ("ENABLED", True, False)
    s = math.sqrt(0.5)
    mtm.move_cp(_pose((0.1, 0.0, 0.0), (0, 0, s, s)))  # no hand on it: the arm moves the grip there
    mtm.tick(0.01, op)
    assert np.allclose(mtm.pose[:3, 3], [0.1, 0, 0])
    assert np.allclose(mtm.pose[:3, :3], [[0, -1, 0], [1, 0, 0], [0, 0, 1]])
    op.hands["MTMR"], op.grips["MTMR"] = np.array([0.01, 0.02, 0.03]), 0.5
    mtm.tick(0.01, op)
    assert np.allclose(mtm.pose[:3, 3], [0.01, 0.02, 0.03]) and mtm.gripper == 0.5
    mtm.move_cp(_pose((0.3, 0.3, 0.3), (0, 0, 0, 1)))  # held: the wrist turns, the hand keeps the position
    mtm.tick(0.01, op)
    assert np.allclose(mtm.pose[:3, 3], [0.01, 0.02, 0.03]) and np.allclose(mtm.pose[:3, :3], np.eye(3))
    mtm.lock_orientation([0, 0, s, s])
    mtm.move_cp(_pose((0, 0, 0), (0, 0, 0, 1)))  # locked: the orientation stays
    assert np.allclose(mtm.pose[:3, :3], [[0, -1, 0], [1, 0, 0], [0, 0, 1]])
    assert mtm.lock_orientation([0, 0, 0, 2])[0][0] == "error"
    assert mtm.servo_cf([0.0] * 6) == [] and mtm.servo_cf([1.0, 0, 0, 0, 0, 0])[0][0] == "warning"
    op.grips["MTMR"] = 5.0  # beyond the gripper's range: clipped
    mtm.tick(0.01, op)
    assert mtm.gripper == pytest.approx(1.2)


def test_scripted_operator_interpolates_and_switches_pedals():
    script = ScriptedOperator([Keyframe(1.0, {"MTMR": (0.0, 0.0, 0.0)}, {"MTMR": 0.2}, {"present": True}),
                               Keyframe(3.0, {"MTMR": (0.02, 0.0, -0.01)}, {"MTMR": 0.6}, {"clutch": True})])
    op = Operator(["MTMR"])
    script.apply(0.5, op)
    assert "MTMR" not in op.hands and not op.present  # before the first keyframe: nothing yet
    script.apply(2.0, op)
    assert np.allclose(op.hands["MTMR"], [0.01, 0.0, -0.005]) and op.grips["MTMR"] == pytest.approx(0.4)
    assert op.present and not op.clutch
    script.apply(9.0, op)
    assert np.allclose(op.hands["MTMR"], [0.02, 0.0, -0.01]) and op.clutch and op.present
    assert op.pedals() == {"clutch": True, "camera": False, "operator_present": True}


def test_operator_keyframes_from_the_scene_file():
    scene = parse_scene("cart:\n  ECM: {}\n  PSM1: {}\n  MTMR: {}\n  operator:\n"
                        "    - {at: 0.5, present: true, MTMR: {position: [0, 0, 0], gripper: 0.3}}\n"
                        "    - {at: 1.5, clutch: true}\n", "cart.yaml")
    assert [k.at for k in scene.operator] == [0.5, 1.5]
    assert scene.operator[0].hands == {"MTMR": (0.0, 0.0, 0.0)} and scene.operator[1].pedals == {"clutch": True}
    with pytest.raises(SceneError, match=r"cart.yaml:7:.*cart.operator\[1\].at: 0.5 s is not after"):
        parse_scene("cart:\n  ECM: {}\n  PSM1: {}\n  MTMR: {}\n  operator:\n"
                    "    - {at: 0.5}\n    - {at: 0.5}\n", "cart.yaml")
    with pytest.raises(SceneError, match=r"cart.operator\[0\].MTML: unknown field"):
        parse_scene("cart:\n  ECM: {}\n  PSM1: {}\n  MTMR: {}\n  operator:\n    - {at: 0.5, MTML: {}}\n", "cart.yaml")


@pytest.mark.parametrize("name", ["MTML", "MTMR"])
def test_mtm_joints_give_its_cartesian_pose(name):
    """The MTM is its 7-joint arm (the dVRK's DH tables): wherever the hand and the wrist put the
    grip, the FK of its joints (measured_js) is local/measured_cp, and in MTMx_base measured_cp,
    which is where they were asked to be; the joints stay within the limits; out of reach, the
    grip stops where the arm gets, its pose still the FK of its joints."""
    from scipy.spatial.transform import Rotation

    from cressim.robots.mtm import MTM_HOME, mtm_forward_kinematics, mtm_jacobian, mtm_limits

    # at home the upper arm (0.2794 m) hangs down, the forearm (0.3645 m) points at the operator and
    # the wrist platform (0.1506 m) rises to the grip: the dVRK's link lengths, put together by hand
    assert np.allclose(mtm_forward_kinematics(name, MTM_HOME)[:3, 3], [0.0, -0.3645, 0.1506 - 0.2794], atol=1e-12)
    mtm, op = MtmArm(name), Operator([name])
    for command in ("enable", "home"):
        mtm.state_command(command)
    assert np.array_equal(mtm.q, MTM_HOME) and np.allclose(mtm.pose, np.eye(4), atol=1e-12)
    lower, upper = mtm_limits(name)
    rng = np.random.default_rng(3)
    for _ in range(20):
        hand = rng.uniform(-0.05, 0.05, 3)
        xyzw = Rotation.from_rotvec(rng.uniform(-0.4, 0.4, 3)).as_quat()
        mtm.move_cp(_pose(hand, xyzw))
        op.hands[name] = hand
        mtm.tick(0.01, op)
        assert np.allclose(mtm.local, mtm_forward_kinematics(name, mtm.q), atol=1e-12)
        assert np.allclose(mtm.pose, mtm.base @ mtm.local, atol=1e-9)  # the IK's tolerance
        assert np.allclose(mtm.pose[:3, 3], hand, atol=1e-9)
        assert np.allclose(mtm.pose[:3, :3], Rotation.from_quat(xyzw).as_matrix(), atol=1e-8)
        assert np.all(mtm.q >= lower) and np.all(mtm.q <= upper)
    # the Jacobian the IK steps with is the FK's derivative (central differences)
    q, eps = mtm.q, 1e-6
    J, _ = mtm_jacobian(name, q)
    for i in range(7):
        dq = np.zeros(7)
        dq[i] = eps
        dp = (mtm_forward_kinematics(name, q + dq)[:3, 3] - mtm_forward_kinematics(name, q - dq)[:3, 3]) / (2 * eps)
        assert np.allclose(dp, J[:3, i], atol=1e-8)
    op.hands[name] = np.array([0.0, 0.0, 1.5])  # 1.5 m: beyond the arm's reach
    mtm.tick(0.01, op)
    assert np.linalg.norm(mtm.pose[:3, 3] - op.hands[name]) > 0.5
    assert np.allclose(mtm.pose, mtm.base @ mtm_forward_kinematics(name, mtm.q), atol=1e-12)
    assert np.all(mtm.q >= lower) and np.all(mtm.q <= upper)
