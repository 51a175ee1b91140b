"""The console without ROS (cressim.twin.mtm): the MTM follows the operator's hand and its wrist
commands, the scripted operator interpolates its keyframes, the scene file's `cart.operator`."""
import math

import numpy as np
import pytest
from types import SimpleNamespace

from cressim.twin import parse_scene
from cressim.twin.mtm import Keyframe, MtmArm, Operator, ScriptedOperator
from cressim.twin.scene import SceneError


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
