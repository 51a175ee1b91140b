"""cressim.robots.chain on URDFs other than the PSM's: the ECM against the dVRK's DH table, a small
tree with every joint type, mimic gains and offsets and a tip offset against yourdfpy, Jacobians
against finite differences, and the HLSL backend's steps against the torch backend."""
import math

import numpy as np
import pytest
import torch
import yourdfpy

from cressim.robots.chain import FIXED, PRISMATIC, REVOLUTE, Chain
from cressim.robots.dvrk import ECM_JOINTS
from cressim.robots.dvrk_dh import ecm_forward_kinematics as dh_ecm
from cressim.robots.ecm import ECM_LOWER, ECM_UPPER, ecm_chain, ecm_forward_kinematics, ecm_inverse_kinematics, ecm_jacobian

# a base, a yaw on a fixed riser, a slider, a continuous roll, a mimic hinge (gain -0.5, offset
# 0.1) on a branch, a fixed tool with a tip offset: every joint kind, axes not along z
TREE = """<robot name="tree">
  <link name="base"/><link name="riser"/><link name="arm"/><link name="slide"/><link name="hand"/>
  <link name="finger"/><link name="tool"/>
  <joint name="riser" type="fixed"><parent link="base"/><child link="riser"/>
    <origin xyz="0 0 0.3" rpy="0.1 0 0"/></joint>
  <joint name="a" type="revolute"><parent link="riser"/><child link="arm"/>
    <origin xyz="0.05 0 0.1" rpy="0 0.2 0.3"/><axis xyz="0 0.6 0.8"/>
    <limit lower="-2" upper="2" effort="5" velocity="1"/></joint>
  <joint name="b" type="prismatic"><parent link="arm"/><child link="slide"/>
    <origin xyz="0.2 0 0" rpy="0 0 0.5"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="0.1" effort="20" velocity="0.2"/></joint>
  <joint name="c" type="continuous"><parent link="slide"/><child link="hand"/>
    <origin xyz="0.1 0.02 0" rpy="0.3 0 0"/><axis xyz="1 1 0"/></joint>
  <joint name="f" type="revolute"><parent link="hand"/><child link="finger"/>
    <origin xyz="0 0.03 0" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/><mimic joint="a" multiplier="-0.5" offset="0.1"/></joint>
  <joint name="tool" type="fixed"><parent link="hand"/><child link="tool"/>
    <origin xyz="0.04 0 0.01" rpy="0 -0.4 0"/></joint>
</robot>"""
TIP_OFFSET = np.array([[0.0, -1.0, 0.0, 0.01], [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.02], [0, 0, 0, 1]])


@pytest.fixture(scope="module")
def tree(tmp_path_factory):
    path = tmp_path_factory.mktemp("tree") / "tree.urdf"
    path.write_text(TREE)
    return path


def random_q(n, lower, upper, seed=0):
    return np.random.default_rng(seed).uniform(lower, upper, size=(n, len(lower)))


def finite_difference_jacobian(chain, q, h=1e-6):
    """(M, 6, C) of the tip: central differences of its position and of its rotation (skew(w))."""
    T = chain.forward(q)
    cols = []
    for j in range(q.shape[1]):
        dq = np.zeros(q.shape[1])
        dq[j] = h
        Tp, Tm = chain.forward(q + dq), chain.forward(q - dq)
        v = (Tp[:, :3, 3] - Tm[:, :3, 3]) / (2 * h)
        dR = (Tp[:, :3, :3] - Tm[:, :3, :3]) / (2 * h) @ T[:, :3, :3].transpose(0, 2, 1)
        cols.append(np.concatenate([v, np.stack([dR[:, 2, 1], dR[:, 0, 2], dR[:, 1, 0]], -1)], -1))
    return np.stack(cols, -1)


def test_tree_equals_yourdfpy(tree):
    chain = Chain(tree, tip="tool", tip_offset=TIP_OFFSET)
    assert chain.sources == ("a", "b", "c") and sorted(chain.joint_names) == ["a", "b", "c", "f"]
    assert [chain.joint_types[chain.joint_names.index(n)] for n in "abcf"] == [REVOLUTE, PRISMATIC, REVOLUTE, REVOLUTE]
    urdf = yourdfpy.URDF.load(str(tree), load_meshes=False)
    q = random_q(50, [-2, 0, -6], [2, 0.1, 6])
    F = chain.link_poses(q)
    tip = chain.forward(q)
    for k, qk in enumerate(q):
        urdf.update_cfg(dict(zip("abc", qk)))
        for i, link in enumerate(chain.links):
            assert np.abs(F[k, i] - urdf.get_transform(link, "base")).max() < 1e-12, link
        assert np.abs(tip[k] - urdf.get_transform("tool", "base") @ TIP_OFFSET).max() < 1e-12
    # the mimic joint's value: gain x source + offset
    assert np.allclose(chain.values(q)[:, chain.joint_names.index("f")], -0.5 * q[:, 0] + 0.1)


def test_tree_jacobian_matches_finite_differences(tree):
    chain = Chain(tree, tip="tool", tip_offset=TIP_OFFSET)
    q = random_q(16, [-2, 0, -6], [2, 0.1, 6], seed=1)
    J, T = chain.jacobian(q)
    assert J.shape == (16, 6, 3) and np.allclose(T, chain.forward(q))
    assert np.abs(J - finite_difference_jacobian(chain, q)).max() < 1e-7


def test_batches_dtypes_and_shapes(tree):
    chain = Chain(tree, tip="tool")
    q = torch.as_tensor(random_q(6, [-2, 0, -6], [2, 0.1, 6], seed=2))
    assert chain.forward(q[0]).shape == (4, 4)
    assert chain.forward(q.reshape(2, 3, 3)).shape == (2, 3, 4, 4)
    T32 = chain.forward(q.float())
    assert T32.dtype == torch.float32 and torch.allclose(T32.double(), chain.forward(q), atol=1e-5)
    J, _ = chain.jacobian(q.reshape(2, 3, 3))
    assert J.shape == (2, 3, 6, 3)
    with pytest.raises(ValueError, match="expected"):
        chain.forward(q[:, :2])
    with pytest.raises(ValueError, match="not one of the sources"):
        Chain(tree, sources=("b", "c"))  # a's joints (and its mimic) need a column
    # a column no joint reads is allowed: its Jacobian column is 0
    wide = Chain(tree, sources=("a", "b", "c", "unused"), tip="tool")
    J, _ = wide.jacobian(torch.cat([q, torch.ones(6, 1, dtype=q.dtype)], 1))
    assert torch.equal(J[..., 3], torch.zeros_like(J[..., 3]))


def walk_steps(steps, ranges, i, qk):
    """Link i's pose from the HLSL backend's table, walked in numpy as link_poses.hlsl walks it
    (each step's origin, then the joint's motion)."""
    T = np.eye(4)
    first, count = ranges[i]
    for s in steps[first: first + count].astype(np.float64):
        x, y, z, w = s[1]
        R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                      [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                      [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
        O = np.eye(4)
        O[:3, :3], O[:3, 3] = R, s[0, :3]
        T = T @ O
        if s[0, 3] == FIXED:
            continue
        value = s[2, 3] * qk[int(s[3, 0])] + s[3, 1]
        M = np.eye(4)
        if s[0, 3] == REVOLUTE:
            a = s[2, :3]
            K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
            M[:3, :3] = np.eye(3) + math.sin(value) * K + (1 - math.cos(value)) * K @ K
        else:
            M[:3, 3] = s[2, :3] * value
        T = T @ M
    return T


def test_steps_are_the_torch_chain(tree):
    """The HLSL backend's table walked as link_poses.hlsl walks it gives the torch backend's
    link poses."""
    chain = Chain(tree, tip="tool")
    links = ["base", "arm", "finger", "tool"]
    steps, ranges = chain.steps(links)
    assert steps.dtype == np.float32 and ranges.shape == (4, 2)
    q = random_q(5, [-2, 0, -6], [2, 0.1, 6], seed=3)
    expected = chain.link_poses(q)
    for k, qk in enumerate(q):
        for i, link in enumerate(links):
            T = walk_steps(steps, ranges, i, qk)
            assert np.abs(T - expected[k, chain.links.index(link)]).max() < 1e-6, link


def test_the_parallelogram_compiles_to_one_hinge():
    """Asked for the tip and the shaft only, the PSM's three parallelogram joints (pitch, pitch_top
    -1, pitch_front) become one hinge about the RCM: 6 frames to the tip, not 8; FK, Jacobian and
    the HLSL steps equal the uncompiled chain's (every link asked for)."""
    from cressim.robots.dvrk import PSM_JOINTS
    from cressim.robots.psm import BASE_LINK, SHAFT_LINK, TIP_LINK, robot_dir

    path = robot_dir() / "psm_lnd.urdf"
    lean = Chain(path, sources=PSM_JOINTS, base=BASE_LINK, tip=TIP_LINK, links=(SHAFT_LINK, TIP_LINK))
    full = Chain(path, sources=(*PSM_JOINTS, "jaw"), base=BASE_LINK, tip=TIP_LINK)
    assert len(lean.tip_path) == 6 and len(full.tip_path) == 8
    q = random_q(100, [-1.5, -0.9, 0, -4.5, -1.3, -1.3], [1.5, 0.9, 0.24, 4.5, 1.3, 1.3], seed=4)
    qj = np.concatenate([q, np.zeros((100, 1))], 1)
    assert np.abs(lean.forward(q) - full.forward(qj)).max() < 1e-9
    assert np.abs(lean.jacobian(q)[0] - full.jacobian(qj)[0][..., :6]).max() < 1e-9
    expected = full.link_poses(qj)[:, [full.links.index(SHAFT_LINK), full.links.index(TIP_LINK)]]
    assert np.abs(lean.link_poses(q) - expected).max() < 1e-9
    # a link at the end of the merged run (the parallelogram's front bar) stays where it was
    front = Chain(path, sources=PSM_JOINTS, base=BASE_LINK, links=("PSM1_pitch_front_link",))
    assert len(front._fparent) == 2
    assert np.abs(front.link_poses(q)[:, 0] - full.link_poses(qj)[:, full.links.index("PSM1_pitch_front_link")]).max() < 1e-9
    steps, ranges = lean.steps([SHAFT_LINK, TIP_LINK])
    assert ranges[1, 1] == 7  # 6 frames and the fixed step to the tip
    for k in range(5):
        for i in range(2):
            assert np.abs(walk_steps(steps, ranges, i, q[k]) - expected[k, i]).max() < 1e-6


def test_ecm_chain_equals_the_dvrk_dh_table():
    """Our ECM URDF's frames equal the DH table's (the dVRK's ecm.json) over random joint values,
    to 1e-9 m; its Jacobian equals finite differences."""
    chain = ecm_chain()
    assert chain.sources == ECM_JOINTS and chain.joint_names == ECM_JOINTS
    q = random_q(200, ECM_LOWER, ECM_UPPER)
    assert np.abs(ecm_forward_kinematics(q) - dh_ecm(q)).max() < 1e-9
    assert np.abs(ecm_forward_kinematics(q, all_frames=True) - dh_ecm(q, all_frames=True)).max() < 1e-9
    # at zero the scope points straight down from its RCM, the tip 0.7 mm past it (0.3829 - 0.3822 m)
    assert np.allclose(dh_ecm(np.zeros(4))[:3, 2:], [[0, 0], [0, 0], [-1, -0.0007]], atol=1e-12)
    assert np.allclose(ecm_forward_kinematics(np.zeros(4))[:3, 2:], [[0, 0], [0, 0], [-1, -0.0007]], atol=1e-11)
    J, T = ecm_jacobian(q[:16])
    assert np.abs(J - finite_difference_jacobian(chain, q[:16])).max() < 1e-7
    back, ok = ecm_inverse_kinematics(T[3])
    assert ok and np.allclose(back, q[3], atol=1e-9)
