"""ArmBodies' dynamic mode on a URDF that is not the dVRK's: a 3-joint arm (two hinges and a
slider, with limits) written here. The engine's jointed arm tracks joint targets, and its bodies
sit where the URDF chain's FK of the measured joints puts their links."""
import numpy as np
import pytest
import torch

from cressim.robots.arm_bodies import ArmBodies

pytest.importorskip("cressim._core")

ARM = """<robot name="three">
  <link name="base">
    <inertial><mass value="1.0"/><inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>
    <collision><geometry><box size="0.1 0.1 0.05"/></geometry></collision></link>
  <link name="column">
    <inertial><origin xyz="0 0 0.1"/><mass value="0.4"/>
      <inertia ixx="0.002" ixy="0" ixz="0" iyy="0.002" iyz="0" izz="0.0005"/></inertial>
    <collision><origin xyz="0 0 0.1"/><geometry><cylinder radius="0.02" length="0.2"/></geometry></collision></link>
  <link name="boom">
    <inertial><origin xyz="0.15 0 0"/><mass value="0.3"/>
      <inertia ixx="0.0002" ixy="0" ixz="0" iyy="0.0025" iyz="0" izz="0.0025"/></inertial>
    <collision><origin xyz="0.15 0 0" rpy="0 1.5707963267948966 0"/>
      <geometry><cylinder radius="0.015" length="0.3"/></geometry></collision></link>
  <link name="carriage">
    <inertial><mass value="0.1"/><inertia ixx="0.0001" ixy="0" ixz="0" iyy="0.0001" iyz="0" izz="0.0001"/></inertial>
    <collision><geometry><box size="0.04 0.03 0.03"/></geometry></collision></link>
  <joint name="turn" type="revolute"><parent link="base"/><child link="column"/>
    <origin xyz="0 0 0.025"/><axis xyz="0 0 1"/><limit lower="-1.5" upper="1.5" effort="20" velocity="1"/></joint>
  <joint name="lift" type="revolute"><parent link="column"/><child link="boom"/>
    <origin xyz="0 0 0.2"/><axis xyz="0 -1 0"/><limit lower="-0.8" upper="0.8" effort="20" velocity="1"/></joint>
  <joint name="reach" type="prismatic"><parent link="boom"/><child link="carriage"/>
    <origin xyz="0.3 0 0"/><axis xyz="1 0 0"/><limit lower="0" upper="0.1" effort="50" velocity="0.2"/></joint>
</robot>"""
JOINTS = ("turn", "lift", "reach")


@pytest.fixture
def arm(tmp_path):
    path = tmp_path / "three.urdf"
    path.write_text(ARM)
    arm = ArmBodies(path, 2, base_position=(0.1, -0.2, 0.05), base_rotation=(0.0, 0.0, 0.3826834323650898, 0.9238795325112867),
                    publish_rate=100.0, physics_rate=2000.0, initial_q=np.zeros(3), initial_jaw=0.0, dof=3,
                    dynamics="dynamic", arm_joints=JOINTS, tip_link="carriage")
    yield arm
    assert arm.engine.validation_messages == [], "\n".join(arm.engine.validation_messages)


def _quat_matrix(x, y, z, w):
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def test_a_non_dvrk_arm_tracks_its_targets_and_its_bodies_follow_the_chain(arm):
    assert [s["kind"] for s in arm._authored[1]] == ["hinge", "hinge", "slider"]
    assert arm.follower_links == ["base"]  # the base alone stays kinematic
    goals = torch.tensor([[0.6, 0.4, 0.07], [-0.9, -0.5, 0.02]], dtype=torch.float64)
    jaw = torch.zeros(2, 1, dtype=torch.float64)
    for _ in range(300):  # 3 s: the ramps at the URDF's velocity limits take 1 s at most
        arm.set_targets(goals, jaw)
        arm.write(arm.read_joints()[0], jaw)
        arm.step()
    q, qd, _, _ = arm.read_joints()
    err = (q - goals).abs()
    assert (err[:, :2] < 2e-3).all() and (err[:, 2] < 1e-3).all(), err
    assert qd.abs().max() < 0.05
    # every dynamic body where the chain puts its links for the measured joints
    positions = np.asarray(arm.engine.buffer("rigid.positions").read())
    rotations = np.asarray(arm.engine.buffer("rigid.rotations").read())
    rows = arm.body_rows.cpu().numpy()
    poses = arm.chain.link_poses(torch.cat([q, jaw], 1)).numpy()
    base = arm.base.numpy()
    for link in ("column", "boom", "carriage"):
        k, frame = arm._body_frames[link]
        for env in range(2):
            body = np.eye(4)
            body[:3, :3] = _quat_matrix(*rotations[rows[env, k]].astype(np.float64))
            body[:3, 3] = positions[rows[env, k], :3]
            expected = base @ poses[env, arm.chain.links.index(link)]
            assert np.abs((body @ frame)[:3, 3] - expected[:3, 3]).max() < 1e-3, (link, env)
            assert np.abs((body @ frame)[:3, :3] - expected[:3, :3]).max() < 5e-3, (link, env)


def test_a_chain_that_is_not_serial_is_refused(tmp_path):
    path = tmp_path / "three.urdf"
    path.write_text(ARM)
    with pytest.raises(ValueError, match="not the serial chain"):
        ArmBodies(path, 1, base_position=(0, 0, 0), base_rotation=(0, 0, 0, 1), publish_rate=100.0,
                  physics_rate=2000.0, initial_q=np.zeros(3), initial_jaw=0.0, dof=3, dynamics="dynamic",
                  arm_joints=("lift", "turn", "reach"), tip_link="carriage")
