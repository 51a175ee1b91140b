"""The dVRK Classic setup joints (SUJ): where each arm's base (its remote centre of motion) sits on
the patient cart for given setup-joint values, from robots/dvrk_suj/suj_classic.urdf on the one
kinematics (cressim.robots.chain).

The URDF is the dVRK's SUJ description (suj-simulated.json, Classic cart: per arm a prismatic
column and five hinges, mounted on the cart and ending at the arm's base frame), written by
robots/dvrk_suj/tools from cressim.robots.dvrk_dh, which tests/robots check it against. Metres and
radians; the cart frame has z up.

    base = suj_base("PSM1", q)     # (4, 4): PSM1_base (its RCM) in the cart's frame
"""
from __future__ import annotations

import functools
from pathlib import Path

import numpy as np

from .chain import Chain
from .dvrk import suj_joints
from .psm import robot_dir

SUJ_ARMS = ("ECM", "PSM1", "PSM2", "PSM3")
# the dVRK's simulated setup-joint values (suj-simulated.json)
SUJ_SIMULATED = {"ECM": (0.6647, 0.5782, -1.2662, 3.7818, 0.0, 0.0),
                 "PSM1": (0.0007, -0.5892, -0.8590, -0.6241, -0.2479, -0.4422),
                 "PSM2": (0.0628, 0.0913, 1.9073, -0.1297, 0.4351, 0.0353),
                 "PSM3": (-0.0261, -1.5892, 1.3076, 0.6994, 0.1361, 0.3359)}


def suj_urdf() -> Path:
    return robot_dir().parent / "dvrk_suj" / "suj_classic.urdf"


@functools.cache
def suj_chain(arm: str) -> Chain:
    """The cart -> `arm`'s base branch of the setup joints' URDF."""
    return Chain(suj_urdf(), sources=suj_joints(arm), base="cart", tip=f"{arm}_base", links=(f"{arm}_base",))


def suj_base(arm: str, q) -> np.ndarray:
    """(4, 4): the base frame (RCM) of `arm` (ECM, PSM1, PSM2, PSM3) in the cart's frame for
    setup-joint values q (6: the column in m, then 5 angles in rad)."""
    if arm not in SUJ_ARMS:
        raise ValueError(f"no setup joints for {arm!r}; the dVRK's Classic cart has {', '.join(SUJ_ARMS)}")
    q = np.asarray(q, dtype=np.float64)
    if q.shape != (6,) or not np.isfinite(q).all():
        raise ValueError(f"{arm} setup joints: 6 finite values expected, got {q.tolist()}")
    return suj_chain(arm).forward(q)


__all__ = ["SUJ_ARMS", "SUJ_SIMULATED", "suj_base", "suj_chain", "suj_urdf"]
