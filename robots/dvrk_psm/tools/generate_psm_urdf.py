"""Write robots/dvrk_psm/psm_lnd.urdf, psm_suction.urdf and meshes/suction_nozzle.obj.

Run from anywhere: `python robots/dvrk_psm/tools/generate_psm_urdf.py` (needs numpy).
The URDFs are outputs: change this script, run it, commit both.

How it works: every joint frame and every shape is placed in PSM1_base coordinates at the
zero configuration (all joints 0); the script turns those world poses into URDF origins
(parent -> child) and link-local shapes. The arm joints sit exactly on the DH frames of
python/cressim/robots/dvrk_dh.py (the dVRK's DH table, the tests' ground truth), so the URDF's forward
kinematics equals the DH table's for every joint vector. The dimensions of links, masses and colours are our own rough choices.
"""
from __future__ import annotations

import importlib.util
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROBOT_DIR = HERE.parent
DH_FILE = ROBOT_DIR.parents[1] / "python" / "cressim" / "robots" / "dvrk_dh.py"


def load_dh():
    # by file path, so that the compiled cressim package need not be importable here
    spec = importlib.util.spec_from_file_location("psm_dh", DH_FILE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


dh = load_dh()


# ---------------------------------------------------------------- small transform helpers
def trans(p):
    T = np.eye(4)
    T[:3, 3] = p
    return T


def rot_to_rpy(R):
    """URDF rpy (R = Rz(yaw) Ry(pitch) Rx(roll)); at gimbal lock roll is 0."""
    pitch = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))
    if math.hypot(R[0, 0], R[1, 0]) < 1e-9:
        return 0.0, pitch, math.atan2(-R[0, 1], R[1, 1])
    return math.atan2(R[2, 1], R[2, 2]), pitch, math.atan2(R[1, 0], R[0, 0])


def rpy_to_rot(r, p, y):
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def z_to(direction):
    """A rotation whose z axis points along `direction` (for cylinders)."""
    z = np.asarray(direction, float) / np.linalg.norm(direction)
    helper = np.array([1.0, 0, 0]) if abs(z[0]) < 0.9 else np.array([0, 1.0, 0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def fmt(v):
    s = f"{v:.12g}"
    return "0" if s in ("-0", "0") else s


def clean(T):
    """Drop floating-point dust (1e-17 and the like) so the URDF reads as the design."""
    T = T.copy()
    T[np.abs(T) < 1e-12] = 0.0
    return T


def xyz_rpy(T):
    T = clean(T)
    r = tuple(0.0 if abs(v) < 1e-12 else v for v in rot_to_rpy(T[:3, :3]))
    assert np.allclose(rpy_to_rot(*r), T[:3, :3], atol=1e-12), "rpy round trip"
    return " ".join(fmt(v) for v in T[:3, 3]), " ".join(fmt(v) for v in r)


# ---------------------------------------------------------------- shapes, links, joints
@dataclass
class Shape:
    kind: str  # cylinder | box | sphere
    pose: np.ndarray  # world pose at zero configuration
    size: tuple  # cylinder (radius, length); box (x, y, z); sphere (radius,)
    visual_mesh: str | None = None  # visual uses this mesh (in link coordinates) instead

    def volume(self):
        if self.kind == "cylinder":
            return math.pi * self.size[0] ** 2 * self.size[1]
        if self.kind == "box":
            return float(np.prod(self.size))
        return 4 / 3 * math.pi * self.size[0] ** 3

    def inertia(self, m):
        """Inertia about the shape's centre, in its own axes."""
        if self.kind == "cylinder":
            r, h = self.size
            i = m * (3 * r * r + h * h) / 12
            return np.diag([i, i, m * r * r / 2])
        if self.kind == "box":
            x, y, z = self.size
            return np.diag([m * (y * y + z * z), m * (x * x + z * z), m * (x * x + y * y)]) / 12
        return np.eye(3) * 0.4 * m * self.size[0] ** 2


def cylinder(p0, p1, radius, **kw):
    p0, p1 = np.asarray(p0, float), np.asarray(p1, float)
    T = trans((p0 + p1) / 2)
    T[:3, :3] = z_to(p1 - p0)
    return Shape("cylinder", T, (radius, float(np.linalg.norm(p1 - p0))), **kw)


def box(center, size):
    return Shape("box", trans(center), tuple(size))


def sphere(center, radius):
    return Shape("sphere", trans(center), (radius,))


@dataclass
class Link:
    name: str
    world: np.ndarray  # link frame at zero configuration
    mass: float = 0.0  # 0: a frame only, no inertial
    material: str = "arm"
    shapes: list = field(default_factory=list)


@dataclass
class Joint:
    name: str
    type: str  # revolute | prismatic | fixed
    parent: str
    child: str
    lower: float = 0.0
    upper: float = 0.0
    effort: float = 0.0
    velocity: float = 0.0
    mimic: tuple | None = None  # (joint, multiplier)


MATERIALS = {
    "arm": "0.20 0.22 0.26 1",  # dark painted aluminium
    "carriage": "0.55 0.57 0.60 1",
    "shaft": "0.05 0.05 0.05 1",  # black instrument shaft
    "metal": "0.78 0.78 0.80 1",  # stainless wrist and jaws
    "tube": "0.90 0.90 0.88 1",  # our suction tube
}

# ---------------------------------------------------------------- the arm, at zero configuration
P = "PSM1_"
dh_frames = dh.dh_forward_kinematics(np.zeros(6), all_frames=True)  # frames 1..6 at q = 0
F1, F2, F3, F4, F5, F6 = (dh_frames[i] for i in range(6))
TIP = F6 @ dh.TOOL_TIP_OFFSET
limits = {r.name: r for r in dh.PSM_DH}

# Pitch parallelogram (our geometry), in the plane x = X_PAR, parallel to the tool's pitch
# plane. Pivot A on the yaw link, B above it, C in front: rotating the back link by q about A,
# the top link by -q about B and the front link by +q about C turns the front link by q about
# the axis through A + C - B, which we put on the pitch axis z2 through the RCM: the tool pivots
# about the RCM as the DH table says (an offset along the axis itself changes nothing).
X_PAR = 0.06
A = np.array([X_PAR, 0.30, 0.0])
B = np.array([X_PAR, 0.30, 0.20])
C = np.array([X_PAR, 0.0, 0.20])
B_LOW = np.array([X_PAR, 0.30, 0.06])  # the lower bar closes the visible parallelogram
C_LOW = np.array([X_PAR, 0.0, 0.06])
assert np.allclose(np.cross(A + C - B - F2[:3, 3], F2[:3, 2]), 0), "it must pivot about the RCM"


def at(point, frame=F2):
    """A joint frame at `point` with the orientation of `frame` (pitch joints: axis = z2)."""
    T = frame.copy()
    T[:3, 3] = point
    return T


Z_TOOL_BASE = F3[2, 3]  # instrument base (top of the shaft) height at zero insertion
Z_WRIST = F4[2, 3]  # wrist pitch axis (shaft end) height at zero insertion
SHAFT_R = 0.0042  # 8.4 mm instrument shaft
VEL = {"yaw": 2.0, "pitch": 2.0, "insertion": 0.4, "roll": 6.0, "wrist_pitch": 6.0, "wrist_yaw": 6.0}


def dh_joint(name, parent, child):
    r = limits[name]
    return Joint(name, r.type, parent, child, r.lower, r.upper, r.effort, VEL[name])


def pitch_mimic(name, parent, child, multiplier):
    lo, hi = limits["pitch"].lower * multiplier, limits["pitch"].upper * multiplier
    return Joint(name, "revolute", parent, child, min(lo, hi), max(lo, hi), limits["pitch"].effort,
                 VEL["pitch"], mimic=("pitch", multiplier))


def arm():
    """Links and joints common to every instrument: base to the rolling shaft (frame 4)."""
    links = [
        Link(P + "base", np.eye(4)),  # the RCM frame, frame 0 of the DH table
        Link(P + "mount_link", trans([0, 0.60, 0]), 2.0, shapes=[box([0, 0.60, 0], [0.10, 0.08, 0.10])]),
        Link(P + "yaw_link", F1, 1.2, shapes=[
            cylinder([0, 0.29, 0], [0, 0.56, 0], 0.035),  # housing along the yaw axis
            box([X_PAR / 2 + 0.01, 0.30, 0], [X_PAR + 0.02, 0.05, 0.04]),  # bracket to pivot A
        ]),
        Link(P + "pitch_back_link", at(A), 0.35, shapes=[cylinder(A - [0, 0, 0.015], B + [0, 0, 0.015], 0.014)]),
        Link(P + "pitch_top_link", at(B), 0.35, shapes=[cylinder(B, C, 0.012)]),
        Link(P + "pitch_bottom_link", at(B_LOW), 0.25, shapes=[cylinder(B_LOW, C_LOW, 0.010)]),
        Link(P + "pitch_front_link", at(C), 0.6, shapes=[
            box([X_PAR, 0, 0.265], [0.02, 0.04, 0.43]),  # front bar and insertion rail
        ]),
        Link(P + "insertion_link", F3, 0.5, "carriage", shapes=[
            box([X_PAR - 0.02, 0, Z_TOOL_BASE + 0.02], [0.025, 0.05, 0.04]),  # carriage on the rail
            box([0, 0, Z_TOOL_BASE + 0.045], [0.055, 0.075, 0.09]),  # instrument housing
        ]),
        Link(P + "shaft_link", F4, 0.08, "shaft", shapes=[
            cylinder([0, 0, Z_TOOL_BASE], [0, 0, Z_WRIST + 0.002], SHAFT_R)]),
    ]
    joints = [
        Joint("mount", "fixed", P + "base", P + "mount_link"),
        dh_joint("yaw", P + "base", P + "yaw_link"),
        dh_joint("pitch", P + "yaw_link", P + "pitch_back_link"),
        pitch_mimic("pitch_top", P + "pitch_back_link", P + "pitch_top_link", -1.0),
        pitch_mimic("pitch_front", P + "pitch_top_link", P + "pitch_front_link", 1.0),
        pitch_mimic("pitch_bottom", P + "pitch_back_link", P + "pitch_bottom_link", -1.0),
        dh_joint("insertion", P + "pitch_front_link", P + "insertion_link"),
        dh_joint("roll", P + "insertion_link", P + "shaft_link"),
    ]
    return links, joints


def large_needle_driver():
    links, joints = arm()
    p4, p6 = F4[:3, 3], F6[:3, 3]
    distal = F4[:3, 2]  # shaft direction, towards the patient
    x6 = F6[:3, 0]  # jaws open along +-x6, rotating about z6 (the wrist yaw axis)
    jaw_len, jaw_w, jaw_t = 0.010, 0.0025, 0.0012

    def jaw_box(side):
        center = p6 + distal * jaw_len / 2 + side * x6 * jaw_t * 0.6
        s = Shape("box", trans(center), (jaw_t, jaw_len, jaw_w))
        s.pose[:3, :3] = F6[:3, :3]  # box x along x6, y along the jaw (y6 = distal), z along z6
        return s

    links += [
        Link(P + "wrist_pitch_link", F5, 0.002, "metal", shapes=[cylinder(p4, p6, 0.0035)]),
        Link(P + "wrist_yaw_link", F6, 0.001, "metal", shapes=[sphere(p6, 0.0025)]),
        Link(P + "jaw_link", F6),  # frame of the virtual `jaw` joint (the opening angle)
        Link(P + "jaw_1_link", F6, 0.0005, "metal", shapes=[jaw_box(-1.0)]),
        Link(P + "jaw_2_link", F6, 0.0005, "metal", shapes=[jaw_box(+1.0)]),
        Link(P + "tool_tip_link", TIP),
    ]
    jaw_lo, jaw_hi = dh.JAW_LIMITS
    joints += [
        dh_joint("wrist_pitch", P + "shaft_link", P + "wrist_pitch_link"),
        dh_joint("wrist_yaw", P + "wrist_pitch_link", P + "wrist_yaw_link"),
        Joint("jaw", "revolute", P + "wrist_yaw_link", P + "jaw_link", jaw_lo, jaw_hi, dh.JAW_EFFORT, 6.0),
        # each jaw turns by half the opening, to either side of the wrist yaw angle
        Joint("jaw_1", "revolute", P + "wrist_yaw_link", P + "jaw_1_link", jaw_lo / 2, jaw_hi / 2,
              dh.JAW_EFFORT, 3.0, mimic=("jaw", 0.5)),
        Joint("jaw_2", "revolute", P + "wrist_yaw_link", P + "jaw_2_link", -jaw_hi / 2, -jaw_lo / 2,
              dh.JAW_EFFORT, 3.0, mimic=("jaw", -0.5)),
        Joint("tool_tip", "fixed", P + "wrist_yaw_link", P + "tool_tip_link"),
    ]
    return "psm_lnd", links, joints


# Our suction/irrigator: a straight hollow nozzle at the end of the same shaft, no wrist. Its
# tip frame is where the needle driver's is with the wrist at zero (DH FK with q5 = q6 = 0,
# times the same tool-tip rotation), so a client sees the same frame convention.
NOZZLE_OUTER_R, NOZZLE_INNER_R = 0.0025, 0.0017  # 5.0 mm OD, 3.4 mm bore
NOZZLE_BACK = 0.010  # the nozzle starts this far inside the shaft end


def suction():
    links, joints = arm()
    p4, tip = F4[:3, 3], TIP[:3, 3]
    distal = F4[:3, 2]
    links += [
        Link(P + "suction_tube_link", F4, 0.003, "tube", shapes=[
            cylinder(p4 - distal * NOZZLE_BACK, tip, NOZZLE_OUTER_R, visual_mesh="meshes/suction_nozzle.obj")]),
        Link(P + "tool_tip_link", TIP),
    ]
    joints += [
        Joint("suction_tube", "fixed", P + "shaft_link", P + "suction_tube_link"),
        Joint("tool_tip", "fixed", P + "suction_tube_link", P + "tool_tip_link"),
    ]
    return "psm_suction", links, joints


def nozzle_obj(n=32):
    """Hollow tube along +z of the suction tube link (frame 4), from inside the shaft to the mouth."""
    z0, z1 = -NOZZLE_BACK, float(np.linalg.norm(TIP[:3, 3] - F4[:3, 3]))
    rings = [(NOZZLE_OUTER_R, z0), (NOZZLE_OUTER_R, z1), (NOZZLE_INNER_R, z1), (NOZZLE_INNER_R, z0)]
    lines = ["# suction nozzle: hollow tube, generated by tools/generate_psm_urdf.py", "o suction_nozzle"]
    for r, z in rings:
        for k in range(n):
            a = 2 * math.pi * k / n
            lines.append(f"v {fmt(r * math.cos(a))} {fmt(r * math.sin(a))} {fmt(z)}")
    for ring in range(4):  # outer wall, mouth annulus, inner wall, back annulus; quads as 2 triangles
        a0, b0 = ring * n, ((ring + 1) % 4) * n
        for k in range(n):
            a, b, c, d = a0 + k + 1, a0 + (k + 1) % n + 1, b0 + (k + 1) % n + 1, b0 + k + 1
            lines += [f"f {a} {b} {c}", f"f {a} {c} {d}"]
    return "\n".join(lines) + "\n"


# ---------------------------------------------------------------- URDF text
def inertial_xml(link, inv_world):
    vols = [s.volume() for s in link.shapes]
    masses = [link.mass * v / sum(vols) for v in vols]
    poses = [clean(inv_world @ s.pose) for s in link.shapes]
    com = sum(m * T[:3, 3] for m, T in zip(masses, poses)) / link.mass
    com[np.abs(com) < 1e-12] = 0.0
    inertia = np.zeros((3, 3))
    for s, m, T in zip(link.shapes, masses, poses):
        R, c = T[:3, :3], T[:3, 3] - com
        inertia += R @ s.inertia(m) @ R.T + m * (c @ c * np.eye(3) - np.outer(c, c))  # parallel axes
    inertia[np.abs(inertia) < 1e-15] = 0.0
    i = {k: fmt(inertia[a, b]) for k, (a, b) in
         {"ixx": (0, 0), "ixy": (0, 1), "ixz": (0, 2), "iyy": (1, 1), "iyz": (1, 2), "izz": (2, 2)}.items()}
    return (f'    <inertial>\n      <origin xyz="{" ".join(fmt(v) for v in com)}" rpy="0 0 0"/>\n'
            f'      <mass value="{fmt(link.mass)}"/>\n      <inertia ' +
            " ".join(f'{k}="{v}"' for k, v in i.items()) + "/>\n    </inertial>\n")


def geometry_xml(shape):
    if shape.kind == "cylinder":
        return f'<cylinder radius="{fmt(shape.size[0])}" length="{fmt(shape.size[1])}"/>'
    if shape.kind == "box":
        return f'<box size="{" ".join(fmt(v) for v in shape.size)}"/>'
    return f'<sphere radius="{fmt(shape.size[0])}"/>'


def link_xml(link):
    if not link.shapes:
        return f'  <link name="{link.name}"/>\n'
    inv_world = np.linalg.inv(link.world)
    out = f'  <link name="{link.name}">\n' + inertial_xml(link, inv_world)
    for s in link.shapes:
        xyz, rpy = xyz_rpy(inv_world @ s.pose)
        origin = f'<origin xyz="{xyz}" rpy="{rpy}"/>'
        visual_geom = geometry_xml(s)
        visual_origin = origin
        if s.visual_mesh:  # meshes are written in link coordinates
            visual_geom, visual_origin = f'<mesh filename="{s.visual_mesh}"/>', '<origin xyz="0 0 0" rpy="0 0 0"/>'
        out += (f'    <visual>\n      {visual_origin}\n      <geometry>{visual_geom}</geometry>\n'
                f'      <material name="{link.material}"/>\n    </visual>\n'
                f'    <collision>\n      {origin}\n      <geometry>{geometry_xml(s)}</geometry>\n    </collision>\n')
    return out + "  </link>\n"


def joint_xml(joint, world):
    xyz, rpy = xyz_rpy(np.linalg.inv(world[joint.parent]) @ world[joint.child])
    out = (f'  <joint name="{joint.name}" type="{joint.type}">\n'
           f'    <parent link="{joint.parent}"/>\n    <child link="{joint.child}"/>\n'
           f'    <origin xyz="{xyz}" rpy="{rpy}"/>\n')
    if joint.type != "fixed":
        out += ('    <axis xyz="0 0 1"/>\n'
                f'    <limit lower="{fmt(joint.lower)}" upper="{fmt(joint.upper)}" '
                f'effort="{fmt(joint.effort)}" velocity="{fmt(joint.velocity)}"/>\n')
    if joint.mimic:
        out += f'    <mimic joint="{joint.mimic[0]}" multiplier="{fmt(joint.mimic[1])}" offset="0"/>\n'
    return out + "  </joint>\n"


def urdf_xml(name, links, joints):
    world = {link.name: link.world for link in links}
    out = ('<?xml version="1.0"?>\n'
           "<!-- Generated by robots/dvrk_psm/tools/generate_psm_urdf.py: edit that, not this file.\n"
           "     CRESSim's own model of the dVRK PSM; joint frames follow the dVRK modified-DH table.\n"
           "     Frames: PSM1_base is the RCM (DH frame 0); PSM1_tool_tip_link is the tool tip. -->\n"
           f'<robot name="{name}">\n')
    out += "".join(f'  <material name="{m}"><color rgba="{c}"/></material>\n' for m, c in MATERIALS.items())
    out += "".join(link_xml(link) for link in links)
    out += "".join(joint_xml(joint, world) for joint in joints)
    return out + "</robot>\n"


def write_all(out_dir=ROBOT_DIR):
    """Write the URDFs and the nozzle mesh under out_dir (tests write to a temporary one)."""
    out_dir = Path(out_dir)
    (out_dir / "meshes").mkdir(parents=True, exist_ok=True)
    (out_dir / "meshes" / "suction_nozzle.obj").write_text(nozzle_obj())
    for build in (large_needle_driver, suction):
        name, links, joints = build()
        (out_dir / f"{name}.urdf").write_text(urdf_xml(name, links, joints))
        print("wrote", out_dir / f"{name}.urdf")


if __name__ == "__main__":
    write_all()
