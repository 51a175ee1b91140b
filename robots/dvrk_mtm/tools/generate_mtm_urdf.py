"""Write robots/dvrk_mtm/mtml.urdf and mtmr.urdf: the dVRK MTMs' kinematics as URDF chains.

Run from anywhere: `python robots/dvrk_mtm/tools/generate_mtm_urdf.py` (needs numpy). The URDFs
are outputs: change this script, run it, commit both.

From the MTMs' standard-DH tables in python/cressim/robots/dvrk_dh.py (the dVRK's mtml.json and
mtmr.json, the tests' ground truth): T_i = Rz(q_i) [Rz(offset) Tz(d) Tx(a) Rx(alpha)], so each
joint turns about z of the frame before it (origin identity), and a fixed joint after it carries
the row's constant part to DH frame i, the link `<side>_<joint>_link`; frame 7 (the grip) is the
wrist roll's. Kinematics only: no geometry, no mass. Numbers are written in full (17 digits).
"""
from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROBOT_DIR = HERE.parent
ROBOTS_PY = ROBOT_DIR.parents[1] / "python" / "cressim" / "robots"
DH_FILE = ROBOTS_PY / "dvrk_dh.py"


def load(name, path):
    # by file path, so that the compiled cressim package need not be importable here
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def rpy(R):
    """URDF rpy of R = Rz(yaw) Ry(pitch) Rx(roll); at gimbal lock roll is 0."""
    pitch = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))
    if math.hypot(R[0, 0], R[1, 0]) < 1e-12:
        return 0.0, pitch, math.atan2(-R[0, 1], R[1, 1])
    return math.atan2(R[2, 1], R[2, 2]), pitch, math.atan2(R[1, 0], R[0, 0])


def num(v: float) -> str:
    v = float(v)
    return "0" if abs(v) < 1e-15 else repr(v)


def origin_xml(T) -> str:
    return (f'<origin xyz="{" ".join(num(v) for v in T[:3, 3])}" '
            f'rpy="{" ".join(num(v) for v in rpy(np.asarray(T)[:3, :3]))}"/>')


def joint_xml(name, kind, parent, child, T=None, limits=None) -> str:
    lines = [f'  <joint name="{name}" type="{kind}">', f'    <parent link="{parent}"/>', f'    <child link="{child}"/>']
    if T is not None:
        lines.append("    " + origin_xml(T))
    if kind != "fixed":
        lines.append('    <axis xyz="0 0 1"/>')
    if limits is not None:
        lines.append(f'    <limit lower="{num(limits[0])}" upper="{num(limits[1])}" effort="0" velocity="0"/>')
    lines.append("  </joint>")
    return "\n".join(lines)


def urdf_xml(name, links, joints, note) -> str:
    body = [f'<?xml version="1.0"?>', f"<!-- {note} -->", f'<robot name="{name}">']
    body += [f'  <link name="{link}"/>' for link in links] + joints + ["</robot>", ""]
    return "\n".join(body)


def mtm_urdf(side: str, dh, names) -> str:
    links, joints, parent = [f"{side}_base"], [], f"{side}_base"
    for joint, row in zip(names.MTM_JOINTS, dh.MTM_DH[side]):
        axis_link, frame_link = f"{side}_{joint}_axis", f"{side}_{joint}_link"
        links += [axis_link, frame_link]
        joints.append(joint_xml(joint, "revolute", parent, axis_link, limits=(row.lower, row.upper)))
        joints.append(joint_xml(f"{joint}_dh", "fixed", axis_link, frame_link, dh.standard_dh_link(row, 0.0)))
        parent = frame_link
    return urdf_xml(side, links, joints, f"The dVRK {side}'s kinematics (written by tools/generate_mtm_urdf.py)")


def write_all(out_dir=ROBOT_DIR) -> None:
    dh, names = load("mtm_dh", DH_FILE), load("dvrk_names", ROBOTS_PY / "dvrk.py")
    for side in names.MTM_ARMS:
        path = Path(out_dir) / f"{side.lower()}.urdf"
        path.write_text(mtm_urdf(side, dh, names))
        print("wrote", path)


if __name__ == "__main__":
    write_all()
