"""The dVRK Classic setup joints (SUJ): where each arm's base (its remote centre of motion) sits on
the patient cart for given setup-joint values.

Facts from the dVRK's own SUJ description (sawIntuitiveResearchKit share/arm/suj-simulated.json,
Classic cart): each SUJ is a modified-DH chain (a prismatic column, then revolute joints), mounted
at `world-origin-to-suj` on the cart and ending at `suj-tip-to-tool-origin`, the arm's base frame;
the code is ours. Metres and radians; the cart frame has z up. Numpy only (the scene parser
uses it).

    base = suj_base("PSM1", q)     # (4, 4): PSM1_base (its RCM) in the cart's frame
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np


class SujLink(NamedTuple):
    alpha: float
    a: float
    d: float
    prismatic: bool
    offset: float


_PSM12 = (SujLink(0.0, 0.0896, 0.0, True, 0.0), SujLink(0.0, 0.0, 0.4166, False, 0.0),
          SujLink(0.0, 0.4318, 0.1429, False, 0.0), SujLink(0.0, 0.4318, -0.1302, False, math.pi / 2),
          SujLink(math.pi / 2, 0.0, 0.4089, False, 0.0), SujLink(-math.pi / 2, 0.0, -0.1029, False, -math.pi / 2))
SUJ_DH = {
    "ECM": (SujLink(0.0, 0.0896, 0.0, True, 0.0), SujLink(0.0, 0.0, 0.4166, False, 0.0),
            SujLink(0.0, 0.4318, 0.1429, False, 0.0), SujLink(0.0, 0.4318, -0.3459, False, math.pi / 2),
            SujLink(-0.7853, 0.0, 0.0, False, math.pi / 2), SujLink(0.0, -0.0667, 0.0, False, 0.0)),
    "PSM1": _PSM12,
    "PSM2": _PSM12,
    "PSM3": (SujLink(0.0, 0.0896, 0.0, True, 0.0), SujLink(0.0, 0.0, 0.3404, False, 0.0),
             SujLink(0.0, 0.5842, 0.1429, False, 0.0), SujLink(0.0, 0.4318, 0.2571, False, math.pi / 2),
             SujLink(math.pi / 2, 0.0, 0.4089, False, 0.0), SujLink(-math.pi / 2, 0.0, -0.1029, False, -math.pi / 2)),
}


def _frame(translation, rotation) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = rotation, translation
    return T


_RZ90 = [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
_RZ180 = [[-1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]]
_RZ_90 = [[0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
CART_TO_SUJ = {"ECM": _frame([0.0, 0.0, 0.43], _RZ90), "PSM1": _frame([-0.1016, -0.1016, 0.43], _RZ180),
               "PSM2": _frame([0.1016, -0.1016, 0.43], np.eye(3)), "PSM3": _frame([0.0, 0.0, 0.1264], _RZ90)}
SUJ_TIP_TO_BASE = {"ECM": _frame([0.6126, 0.0, 0.1016], _RZ_90), "PSM1": _frame([0.4864, 0.0, 0.1524], _RZ_90),
                   "PSM2": _frame([0.4864, 0.0, 0.1524], _RZ_90), "PSM3": _frame([0.4864, 0.0, 0.1524], _RZ_90)}
# the dVRK's simulated setup-joint values (suj-simulated.json)
SUJ_SIMULATED = {"ECM": (0.6647, 0.5782, -1.2662, 3.7818, 0.0, 0.0),
                 "PSM1": (0.0007, -0.5892, -0.8590, -0.6241, -0.2479, -0.4422),
                 "PSM2": (0.0628, 0.0913, 1.9073, -0.1297, 0.4351, 0.0353),
                 "PSM3": (-0.0261, -1.5892, 1.3076, 0.6994, 0.1361, 0.3359)}


def _link(link: SujLink, q: float) -> np.ndarray:
    """Rx(alpha) Tx(a) Rz(theta) Tz(d) (modified DH, as cressim.robots.dh)."""
    theta, d = (link.offset, link.d + q) if link.prismatic else (q + link.offset, link.d)
    ca, sa, ct, st = math.cos(link.alpha), math.sin(link.alpha), math.cos(theta), math.sin(theta)
    return np.array([[ct, -st, 0.0, link.a],
                     [st * ca, ct * ca, -sa, -sa * d],
                     [st * sa, ct * sa, ca, ca * d],
                     [0.0, 0.0, 0.0, 1.0]])


def suj_base(arm: str, q) -> np.ndarray:
    """(4, 4): the base frame (RCM) of `arm` (ECM, PSM1, PSM2, PSM3) in the cart's frame for
    setup-joint values q (6: the column in m, then 5 angles in rad)."""
    if arm not in SUJ_DH:
        raise ValueError(f"no setup joints for {arm!r}; the dVRK's Classic cart has {', '.join(SUJ_DH)}")
    q = np.asarray(q, dtype=np.float64)
    if q.shape != (6,) or not np.isfinite(q).all():
        raise ValueError(f"{arm} setup joints: 6 finite values expected, got {q.tolist()}")
    T = CART_TO_SUJ[arm].copy()
    for link, value in zip(SUJ_DH[arm], q):
        T = T @ _link(link, float(value))
    return T @ SUJ_TIP_TO_BASE[arm]


__all__ = ["CART_TO_SUJ", "SUJ_DH", "SUJ_SIMULATED", "SUJ_TIP_TO_BASE", "SujLink", "suj_base"]
