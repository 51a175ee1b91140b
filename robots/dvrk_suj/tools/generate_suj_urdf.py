"""Write robots/dvrk_suj/suj_classic.urdf: the dVRK Classic cart's setup joints as URDF chains.

Run from anywhere: `python robots/dvrk_suj/tools/generate_suj_urdf.py` (needs numpy). The URDF is
an output: change this script, run it, commit both.

From the setup joints' modified-DH tables in python/cressim/robots/dvrk_dh.py (the dVRK's
suj-simulated.json, the tests' ground truth): one tree from the cart's frame (`cart`, z up), a
branch per arm: its mount (world-origin-to-suj), six joints (a prismatic column, then hinges;
each joint's origin Rx(alpha) Tx(a) Rz(offset) Tz(d), moving along or about its z) ending at the
link `<arm>_suj_<k>_link` (DH frame k), and the arm's base (suj-tip-to-tool-origin), `<arm>_base`,
its remote centre of motion. No limits are known for the setup joints; kinematics only.
"""
from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROBOT_DIR = HERE.parent
MTM_TOOLS = ROBOT_DIR.parent / "dvrk_mtm" / "tools" / "generate_mtm_urdf.py"


def _load(name, path):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


writer = _load("mtm_urdf_writer", MTM_TOOLS)  # its URDF writers
ARMS = ("ECM", "PSM1", "PSM2", "PSM3")  # the Classic cart's (the tables' keys)


def rx(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0, 0, 0], [0, c, -s, 0], [0, s, c, 0], [0, 0, 0, 1]])


def rz(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]])


def shift(x=0.0, z=0.0):
    T = np.eye(4)
    T[0, 3], T[2, 3] = x, z
    return T


def suj_urdf(dh, names) -> str:
    links, joints = ["cart"], []
    for arm in ARMS:
        mount = f"{arm}_suj_mount"
        links.append(mount)
        joints.append(writer.joint_xml(f"{arm}_suj_mount", "fixed", "cart", mount, dh.CART_TO_SUJ[arm]))
        parent = mount
        for k, link in enumerate(dh.SUJ_DH[arm], start=1):
            child = f"{arm}_suj_{k}_link"
            links.append(child)
            origin = rx(link.alpha) @ shift(x=link.a) @ rz(link.offset) @ shift(z=link.d)
            joints.append(writer.joint_xml(names.suj_joints(arm)[k - 1], "prismatic" if link.prismatic else "continuous",
                                           parent, child, origin))
            parent = child
        links.append(f"{arm}_base")
        joints.append(writer.joint_xml(f"{arm}_suj_tip", "fixed", parent, f"{arm}_base", dh.SUJ_TIP_TO_BASE[arm]))
    return writer.urdf_xml("suj_classic", links, joints,
                           "The dVRK Classic setup joints' kinematics (written by tools/generate_suj_urdf.py)")


def write_all(out_dir=ROBOT_DIR) -> None:
    dh, names = writer.load("suj_dh", writer.DH_FILE), writer.load("dvrk_names", writer.ROBOTS_PY / "dvrk.py")
    path = Path(out_dir) / "suj_classic.urdf"
    path.write_text(suj_urdf(dh, names))
    print("wrote", path)


if __name__ == "__main__":
    write_all()
