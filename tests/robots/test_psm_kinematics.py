"""The PSM URDFs against the dVRK DH table (cressim.robots.dvrk_dh, the ground truth); FK, Jacobian
and IK of cressim.robots.PSM and ArmKinematics."""
import importlib.util
import math
import sys

import numpy as np
import pytest
import torch
import yourdfpy

from cressim.robots import BASE_LINK, PSM, TIP_LINK, ArmKinematics, canonical_joint_name, robot_dir
from cressim.robots.dvrk import PSM_JOINTS, PSM_OLD_JOINTS
from cressim.robots.dvrk_dh import JAW_LIMITS, PSM_DH, dh_forward_kinematics

N = 1000
POSITION_TOL = 1e-4  # 0.1 mm
ROTATION_TOL = math.radians(0.1)


def pose_error(A, B):
    """Largest position (m) and rotation (rad) error between two batches of 4x4 poses."""
    A, B = torch.as_tensor(A, dtype=torch.float64), torch.as_tensor(B, dtype=torch.float64)
    err_p = (A[..., :3, 3] - B[..., :3, 3]).norm(dim=-1)
    R = A[..., :3, :3].transpose(-1, -2) @ B[..., :3, :3]
    sin = torch.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], -1)
    err_r = torch.atan2(sin.norm(dim=-1) / 2, (R.diagonal(dim1=-2, dim2=-1).sum(-1) - 1) / 2)
    return err_p.max().item(), err_r.max().item()


def random_q(psm, n, seed=0):
    g = torch.Generator().manual_seed(seed)
    u = torch.rand(n, psm.dof, generator=g, dtype=torch.float64).to(psm.lower.device)
    return psm.lower.double() + (psm.upper - psm.lower).double() * u


@pytest.fixture(scope="module")
def lnd():
    return PSM("psm_lnd.urdf")


@pytest.fixture(scope="module")
def suction():
    return PSM("psm_suction.urdf")


@pytest.mark.parametrize("name", ["psm_lnd.urdf", "psm_suction.urdf"])
def test_urdf_loads_with_geometry_and_inertials(name):
    path = robot_dir() / name
    urdf = yourdfpy.URDF.load(str(path), load_meshes=True)
    assert urdf.base_link == BASE_LINK
    assert TIP_LINK in urdf.link_map
    for link in urdf.robot.links:
        if link.collisions:  # every body has mass; frame-only links have neither
            assert link.inertial is not None and link.inertial.mass > 0, link.name
            assert np.all(np.linalg.eigvalsh(link.inertial.inertia) > 0), link.name
    # the suction nozzle is a mesh; it must resolve and be a watertight hollow tube
    if "suction" in name:
        mesh = next(iter(urdf.scene.geometry.values()))
        assert mesh.is_watertight and len(mesh.faces) > 0


def test_urdfs_match_their_generator(tmp_path, monkeypatch):
    """The committed URDFs and mesh are what tools/generate_psm_urdf.py writes today."""
    spec = importlib.util.spec_from_file_location("generate_psm_urdf", robot_dir() / "tools" / "generate_psm_urdf.py")
    generator = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, spec.name, generator)  # its dataclasses look themselves up there
    spec.loader.exec_module(generator)
    generator.write_all(tmp_path)
    for name in ("psm_lnd.urdf", "psm_suction.urdf", "meshes/suction_nozzle.obj"):
        assert (tmp_path / name).read_text() == (robot_dir() / name).read_text(), f"regenerate {name}"


def test_limits_and_efforts_match_dh_table(lnd, suction):
    for psm in (lnd, suction):
        rows = PSM_DH[: psm.dof]
        assert psm.joint_names == PSM_JOINTS[: psm.dof]
        assert torch.allclose(psm.lower, torch.tensor([r.lower for r in rows], dtype=psm.dtype))
        assert torch.allclose(psm.upper, torch.tensor([r.upper for r in rows], dtype=psm.dtype))
        assert torch.allclose(psm.effort, torch.tensor([r.effort for r in rows], dtype=psm.dtype))
    assert lnd.dof == 6 and lnd.has_jaw and lnd.jaw_limits == pytest.approx(JAW_LIMITS)
    assert suction.dof == 4 and not suction.has_jaw


def test_chain_fk_equals_dh(lnd):
    q = random_q(lnd, N)
    T = lnd.forward_kinematics(q)
    assert T.shape == (N, 4, 4) and T.dtype == torch.float32
    err_p, err_r = pose_error(T, dh_forward_kinematics(q))
    assert err_p < POSITION_TOL and err_r < ROTATION_TOL
    # in float64 the URDF chain is the DH table to rounding (the URDF's 12-digit numbers)
    psm = PSM("psm_lnd.urdf", dtype=torch.float64)
    err_p, err_r = pose_error(psm.forward_kinematics(q), dh_forward_kinematics(q))
    assert err_p < 1e-9 and err_r < 1e-9


def test_yourdfpy_fk_equals_dh():
    urdf = yourdfpy.URDF.load(str(robot_dir() / "psm_lnd.urdf"), load_meshes=False)
    q = random_q(PSM("psm_lnd.urdf"), N, seed=1)
    T = []
    for qi in q.tolist():
        urdf.update_cfg(dict(zip(PSM_JOINTS, qi)))
        T.append(urdf.get_transform(TIP_LINK, BASE_LINK))
    err_p, err_r = pose_error(np.stack(T), dh_forward_kinematics(q))
    assert err_p < POSITION_TOL and err_r < ROTATION_TOL


def test_suction_tip_is_the_straight_wrist_tip(suction):
    q = random_q(suction, N, seed=2)
    err_p, err_r = pose_error(suction.forward_kinematics(q), dh_forward_kinematics(q))  # q5 = q6 = 0
    assert err_p < POSITION_TOL and err_r < ROTATION_TOL


def test_jaws_open_symmetrically():
    urdf = yourdfpy.URDF.load(str(robot_dir() / "psm_lnd.urdf"), load_meshes=False)
    urdf.update_cfg({"jaw": 0.8})
    for jaw, sign in (("PSM1_jaw_1_link", 1), ("PSM1_jaw_2_link", -1)):
        R = urdf.get_transform(jaw, "PSM1_wrist_yaw_link")[:3, :3]
        assert math.atan2(R[1, 0], R[0, 0]) == pytest.approx(sign * 0.4)


def test_fk_batch_shapes(lnd):
    assert lnd.forward_kinematics(torch.zeros(6)).shape == (4, 4)
    assert lnd.forward_kinematics(torch.zeros(2, 3, 6)).shape == (2, 3, 4, 4)
    with pytest.raises(ValueError):
        lnd.forward_kinematics(torch.zeros(5, 7))


@pytest.mark.parametrize("name", ["psm_lnd.urdf", "psm_suction.urdf"])
def test_interface_kinematics_equal_dh(name):
    """ArmKinematics (what the twin publishes) over the 6-joint interface: FK equals the DH table to
    1e-9, the Jacobian equals the DH frames' (joint i about or along z of frame i); a wrist-less
    tool's wrist columns are 0 and its values are ignored."""
    psm = PSM(name, dtype=torch.float64)
    kin = ArmKinematics(psm, "cpu")
    q = torch.zeros(N, 6, dtype=torch.float64)
    q[:, : psm.dof] = random_q(psm, N, seed=5)
    noise = q.clone()
    noise[:, psm.dof:] = 0.3  # joints the tool lacks
    err_p, err_r = pose_error(kin.forward(noise), dh_forward_kinematics(q))
    assert err_p < 1e-9 and err_r < 1e-9
    J, T = kin.jacobian(noise)
    F = dh_forward_kinematics(q, all_frames=True)
    z, lever = F[..., :3, 2], T[:, None, :3, 3] - F[..., :3, 3]
    prismatic = torch.tensor([r.type == "prismatic" for r in PSM_DH])[None, :, None]
    expected = torch.cat([torch.where(prismatic, z, torch.linalg.cross(z, lever, dim=-1)),
                          torch.where(prismatic, torch.zeros_like(z), z)], -1).transpose(1, 2)
    expected[..., psm.dof:] = 0
    assert torch.allclose(J, expected, atol=1e-9)


def test_jacobian_matches_finite_differences():
    psm = PSM("psm_lnd.urdf", dtype=torch.float64)
    q = random_q(psm, 16, seed=3)
    J, T = psm.jacobian(q, return_pose=True)
    assert J.shape == (16, 6, 6)
    h = 1e-6
    for j in range(6):
        dq = torch.zeros(6, dtype=torch.float64)
        dq[j] = h
        Tp, Tm = psm.forward_kinematics(q + dq), psm.forward_kinematics(q - dq)
        v = (Tp[:, :3, 3] - Tm[:, :3, 3]) / (2 * h)
        dR = (Tp[:, :3, :3] - Tm[:, :3, :3]) / (2 * h) @ T[:, :3, :3].transpose(-1, -2)  # skew(w)
        w = torch.stack([dR[:, 2, 1], dR[:, 0, 2], dR[:, 1, 0]], dim=-1)
        assert torch.allclose(J[:, :3, j], v, atol=1e-6) and torch.allclose(J[:, 3:, j], w, atol=1e-6)


@pytest.mark.parametrize("name", ["psm_lnd.urdf", "psm_suction.urdf"])
def test_ik_round_trip(name):
    psm = PSM(name)
    q = random_q(psm, N, seed=4)
    target = psm.forward_kinematics(q)
    q_ik, ok = psm.inverse_kinematics(target)
    assert ok.all() and psm.within_limits(q_ik).all()
    err_p, err_r = pose_error(psm.forward_kinematics(q_ik), target)
    assert err_p < 1e-5 and err_r < math.radians(0.01)
    # with the true joints as the seed, IK gives them back (roll included, despite its 2 pi span);
    # float64 poses, as near the RCM singularity (insertion ~0.0156 m: the wrist point in the RCM)
    # float32 noise moves the joints, not the pose
    q_seeded, ok = PSM(name, dtype=torch.float64).inverse_kinematics(dh_forward_kinematics(q), seed=q)
    assert ok.all() and torch.allclose(q_seeded, q, atol=1e-9)


def test_unreachable_poses_are_flagged(lnd):
    reachable = dh_forward_kinematics(np.array([0.2, -0.3, 0.12, 1.0, 0.3, -0.2]))
    too_deep = dh_forward_kinematics(np.array([0.0, 0.0, 0.30, 0.0, 0.0, 0.0]))  # insertion > 0.24
    bent_wrist = dh_forward_kinematics(np.array([0.1, 0.2, 0.10, 0.0, 1.55, 0.0]))  # wrist > 80 deg
    upward = reachable.copy()
    upward[:3, :3] = np.diag([1.0, -1.0, -1.0]) @ upward[:3, :3]  # mirror: the tool points up
    upward[2, 3] = 0.1
    poses = torch.tensor(np.stack([reachable, too_deep, bent_wrist, upward]))
    q, ok = lnd.inverse_kinematics(poses)
    assert ok.tolist() == [True, False, False, False]
    assert lnd.within_limits(q).all()  # even a failed solve hands back in-limit joints
    with pytest.raises(ValueError, match="unreachable"):
        lnd.inverse_kinematics(poses, strict=True)


def test_limits_enforced(lnd):
    q = torch.tensor([[2.0, -1.0, 0.3, 5.0, 1.5, -1.5], [0.0, 0.0, 0.1, 0.0, 0.0, 0.0]])
    assert lnd.within_limits(q).tolist() == [False, True]
    clamped = lnd.clamp(q)
    assert lnd.within_limits(clamped).all()
    assert torch.allclose(clamped[0], torch.stack([lnd.upper[0], lnd.lower[1], lnd.upper[2], lnd.upper[3],
                                                   lnd.upper[4], lnd.lower[5]]))


def test_old_and_new_joint_names(lnd):
    values = torch.arange(6, dtype=torch.float32) / 10
    order = [5, 0, 3, 1, 4, 2]
    old = [PSM_OLD_JOINTS[i] for i in order]
    assert torch.equal(lnd.joint_vector(values[order], names=old), values)
    new = [PSM_JOINTS[i] for i in order]
    assert torch.equal(lnd.joint_vector(values[order], names=new), values)
    assert torch.equal(lnd.joint_vector(dict(zip(old, values[order].tolist()))), values)
    assert canonical_joint_name("outer_wrist_yaw") == "wrist_yaw"
    with pytest.raises(ValueError):
        canonical_joint_name("elbow")
    with pytest.raises(ValueError):  # a joint missing
        lnd.joint_vector(values[:5], names=PSM_JOINTS[:5])


@pytest.mark.skipif(not torch.cuda.is_available(), reason="no CUDA device")
def test_fk_and_ik_on_cuda():
    psm = PSM("psm_lnd.urdf", device="cuda")
    q = random_q(psm, 4096).to("cuda")
    T = psm.forward_kinematics(q)
    assert T.device.type == "cuda"
    err_p, err_r = pose_error(T.cpu(), dh_forward_kinematics(q.cpu()))
    assert err_p < POSITION_TOL and err_r < ROTATION_TOL
    assert psm.inverse_kinematics(T).reachable.all()
