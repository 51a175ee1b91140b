"""Write robots/dvrk_ecm/ecm.urdf: CRESSim's own model of the dVRK ECM with a straight endoscope.

Run from anywhere: `python robots/dvrk_ecm/tools/generate_ecm_urdf.py` (needs numpy). The
URDF is an output: change this script, run it, commit both.

As robots/dvrk_psm/tools/generate_psm_urdf.py (whose shape, link and URDF writers this reuses):
every joint frame and shape is placed in ECM_base coordinates at q = 0 and turned into URDF
origins, the arm joints exactly on the DH frames of python/cressim/robots/dvrk_dh.py (the dVRK's
ecm.json, the tests' ground truth), so the URDF's forward kinematics equals the DH table's. The ECM is drawn without its parallelogram (the pitch
link turns about the RCM directly); sizes and colours are our own rough choices.
"""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROBOT_DIR = HERE.parent
DH_FILE = ROBOT_DIR.parents[1] / "python" / "cressim" / "robots" / "dvrk_dh.py"


def _load(name, path):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


# by file path, so that the compiled cressim package need not be importable here
ecm = _load("ecm_dh", DH_FILE)
psm_gen = _load("psm_urdf_generator", ROBOT_DIR.parent / "dvrk_psm" / "tools" / "generate_psm_urdf.py")
Joint, Link, box, cylinder, trans = psm_gen.Joint, psm_gen.Link, psm_gen.box, psm_gen.cylinder, psm_gen.trans

P = "ECM_"
F1, F2, F3, F4 = ecm.ecm_forward_kinematics(np.zeros(4), all_frames=True)
SCOPE_R = 0.006  # a 12 mm stereo endoscope
limits = {r.name: r for r in ecm.ECM_DH}


def dh_joint(name, parent, child, velocity):
    r = limits[name]
    return Joint(name, r.type, parent, child, r.lower, r.upper, r.effort, velocity)


def build():
    base, tip = F3[:3, 3], F4[:3, 3]  # the scope's back end (camera head) and its tip at q = 0
    back = (base - tip) / np.linalg.norm(base - tip)  # from the tip back along the scope
    links = [
        Link(P + "base", np.eye(4)),  # the RCM frame, frame 0 of the DH table
        Link(P + "yaw_link", F1),
        # the arm's body behind the camera head, turning about the RCM with the pitch
        Link(P + "pitch_link", F2, 3.0, shapes=[box(base + back * 0.09, [0.08, 0.08, 0.08])]),
        Link(P + "insertion_link", F3, 0.6, "carriage", shapes=[
            box(base + back * 0.03, [0.05, 0.05, 0.06]),  # the camera head
            cylinder(base, tip + back * 0.001, SCOPE_R)]),  # the scope, up to 1 mm behind its tip (the eyes)
        Link(P + "roll_link", F4),  # DH frame 4: the tip (the cameras look along its z)
    ]
    joints = [
        dh_joint("yaw", P + "base", P + "yaw_link", 1.0),
        dh_joint("pitch", P + "yaw_link", P + "pitch_link", 1.0),
        dh_joint("insertion", P + "pitch_link", P + "insertion_link", 0.2),
        dh_joint("roll", P + "insertion_link", P + "roll_link", 1.0),
    ]
    return "ecm", links, joints


def write_all(out_dir=ROBOT_DIR):
    name, links, joints = build()
    text = psm_gen.urdf_xml(name, links, joints)
    text = text.replace("robots/dvrk_psm/tools/generate_psm_urdf.py", "robots/dvrk_ecm/tools/generate_ecm_urdf.py")
    text = text.replace("the dVRK PSM; joint frames follow the dVRK modified-DH table",
                        "the dVRK ECM; joint frames follow the dVRK modified-DH table")
    text = text.replace("PSM1_base is the RCM (DH frame 0); PSM1_tool_tip_link is the tool tip",
                        "ECM_base is the RCM (DH frame 0); ECM_roll_link is the endoscope tip")
    Path(out_dir).mkdir(parents=True, exist_ok=True)
    (Path(out_dir) / f"{name}.urdf").write_text(text)
    print("wrote", Path(out_dir) / f"{name}.urdf")


if __name__ == "__main__":
    write_all()
