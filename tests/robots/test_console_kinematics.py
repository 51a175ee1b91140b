"""The MTMs' and the setup joints' URDF chains (robots/dvrk_mtm, robots/dvrk_suj) against the
dVRK's DH tables (cressim.robots.dvrk_dh, the ground truth), and the URDFs against their
generators."""
import importlib.util
import sys

import numpy as np
import pytest

from cressim.robots.dvrk import MTM_JOINTS
from cressim.robots.dvrk_dh import MTM_DH, mtm_dh_forward_kinematics, suj_dh_base
from cressim.robots.mtm import mtm_chain, mtm_forward_kinematics, mtm_jacobian, mtm_limits
from cressim.robots.psm import robot_dir
from cressim.robots.suj import SUJ_ARMS, SUJ_SIMULATED, suj_base

ROBOTS = robot_dir().parent


@pytest.mark.parametrize("side", ["MTML", "MTMR"])
def test_mtm_chain_equals_the_dh_table(side):
    chain = mtm_chain(side)
    assert chain.sources == MTM_JOINTS and chain.joint_names == MTM_JOINTS
    lower, upper = mtm_limits(side)
    assert np.allclose(lower, [r.lower for r in MTM_DH[side]]) and np.allclose(upper, [r.upper for r in MTM_DH[side]])
    rng = np.random.default_rng(0)
    for q in rng.uniform(lower, upper, size=(200, 7)):
        assert np.abs(mtm_forward_kinematics(side, q, all_frames=True)
                      - mtm_dh_forward_kinematics(side, q, all_frames=True)).max() < 1e-12
    # the Jacobian: joint i turns about z of DH frame i - 1, at its origin
    q = rng.uniform(lower, upper, size=7)
    F = np.concatenate([np.eye(4)[None], mtm_dh_forward_kinematics(side, q, all_frames=True)])
    z, o = F[:-1, :3, 2], F[:-1, :3, 3]
    J, T = mtm_jacobian(side, q)
    assert np.allclose(J, np.concatenate([np.cross(z, T[:3, 3] - o), z], 1).T, atol=1e-12)


def test_suj_chains_equal_the_dh_table():
    rng = np.random.default_rng(1)
    for arm in SUJ_ARMS:
        for q in [np.array(SUJ_SIMULATED[arm]), *rng.uniform(-1.0, 1.0, size=(50, 6))]:
            assert np.abs(suj_base(arm, q) - suj_dh_base(arm, q)).max() < 1e-12, arm


@pytest.mark.parametrize("tool, outputs", [("dvrk_mtm/tools/generate_mtm_urdf.py", ["mtml.urdf", "mtmr.urdf"]),
                                           ("dvrk_suj/tools/generate_suj_urdf.py", ["suj_classic.urdf"])])
def test_urdfs_match_their_generator(tool, outputs, tmp_path, monkeypatch):
    spec = importlib.util.spec_from_file_location("urdf_generator", ROBOTS / tool)
    generator = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, spec.name, generator)
    spec.loader.exec_module(generator)
    generator.write_all(tmp_path)
    robot = (ROBOTS / tool).parents[1]
    for name in outputs:
        assert (tmp_path / name).read_text() == (robot / name).read_text(), f"regenerate {name}"
