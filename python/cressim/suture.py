"""Suturing helpers (docs/particles.md, "Suturing"): the punctures a cressim.Needle has made, read
back from `particles.punctures`, and a mesh of a needle's arc for its Renderable."""
from __future__ import annotations

import numpy as np

import cressim

FREE, INDENTING, PUNCTURED = 0, 1, 2


def punctures(engine) -> list[list[dict]]:
    """Per needle (in env order), its live puncture records: state (INDENTING: the tip pushes the
    surface ahead; PUNCTURED: the surface point lies on the needle or thread), the surface triangle
    (row of particles.surface) and barycentric weights, the world point, its path parameter s (m
    from the tip along the needle, then the thread), whether the knot holds it, where the tip met the
    surface, the push (N) it took to go through, and (punctured on the thread) the force the puncture put on
    the thread over the last substep (N, world) and its friction part along the thread (N)."""
    if "particles.punctures" not in engine.internal_keys:
        return []
    records = engine.buffer("particles.punctures").read()
    needles = engine.buffer("particles.needles").read()
    surface = engine.buffer("particles.surface").read()
    x = engine.buffer("particles.positions").read()[:, :3]
    out = []
    for n in needles:
        first, count = int(n[4]), int(n[5])
        live = []
        for r in records[first:first + count]:
            if r[0] == FREE:
                continue
            f = r[4:].view(np.float32)
            b = np.array([f[0], f[1], 1 - f[0] - f[1]])
            corners = surface[int(r[1])]
            live.append({"state": int(r[0]), "triangle": int(r[1]), "weights": b, "point": b @ x[corners],
                         "s": float(f[2]), "knot": bool(r[3]), "contact": f[4:7].copy(), "push": float(f[7]),
                         "force": f[8:11].copy(), "friction": float(f[11])})
        out.append(live)
    return out


def thread_tension(engine) -> np.ndarray:
    """Per needle (in env order), its thread's tension (N) once its knot has caught and the thread
    from the needle's tail through its punctures to the knot is taut; 0 while it is slack or the
    knot has not caught. What the needle's holder feels of the thread (docs/particles.md, "Suturing")."""
    if "particles.needle_threads" not in engine.internal_keys:
        return np.zeros(0)
    return engine.buffer("particles.needle_threads").read()[:, 0].astype(np.float64)


STEEL = 7900.0  # kg/m^3: a needle's wire


def needle_body(radius: float, angle: float, wire: float, density: float = STEEL):
    """A needle's mass properties for its rigid body: (mass kg, principal inertia (3,) kg m^2 about
    its centre of mass, the body frame in the arc frame (4x4)). The wire (radius `wire`) is bent on
    the arc (radius `radius`, from angle 0 to `angle`); its centre of mass lies on the bisector at
    radius sin(angle/2) / (angle/2), the body's x along the bisector, z the arc's normal."""
    mass = density * np.pi * wire ** 2 * radius * angle
    half = angle / 2
    phi = np.linspace(-half, half, 2001)  # about the bisector
    d = radius * np.sin(half) / half
    along, across = radius * np.cos(phi) - d, radius * np.sin(phi)
    tube = mass * wire ** 2 / 4  # the wire's own section about a diameter (about z: twice that)
    ixx, iyy = mass * np.mean(across ** 2) + tube, mass * np.mean(along ** 2) + tube
    frame = np.eye(4)
    c, s = np.cos(half), np.sin(half)
    frame[:3, :3] = [[c, -s, 0], [s, c, 0], [0, 0, 1]]
    frame[:3, 3] = [d * c, d * s, 0]
    return mass, np.array([ixx, iyy, ixx + iyy]), frame


def needle_mesh(radius: float, angle: float, wire: float, segments: int = 48, sides: int = 12) -> cressim.Mesh:
    """A needle's arc as a tube of radius `wire` (m) in the xy plane about z, from the tail at angle 0
    to the tip at `angle`, tapering to a point over its last tenth (cressim.Needle's arc frame)."""
    return cressim.Mesh(*needle_arrays(radius, angle, wire, segments, sides))


def needle_arrays(radius: float, angle: float, wire: float, segments: int = 48, sides: int = 12):
    """needle_mesh's (positions, triangles, normals) as numpy arrays."""
    phi = np.linspace(0, angle, segments + 1)
    taper = np.clip((angle - phi) / (0.1 * angle), 0.0, 1.0)
    ring = np.linspace(0, 2 * np.pi, sides, endpoint=False)
    pos, nrm = [], []
    for p, t in zip(phi, taper):
        centre = radius * np.array([np.cos(p), np.sin(p), 0.0])
        out, up = np.array([np.cos(p), np.sin(p), 0.0]), np.array([0.0, 0.0, 1.0])
        for a in ring:
            n = np.cos(a) * out + np.sin(a) * up
            pos.append(centre + max(t, 0.02) * wire * n)
            nrm.append(n)
    tri = []
    for i in range(segments):
        for k in range(sides):
            a, b = i * sides + k, i * sides + (k + 1) % sides
            tri += [(a, b, b + sides), (a, b + sides, a + sides)]
    # the tail's cap
    base = len(pos)
    pos.append(np.array([radius, 0.0, 0.0]))
    nrm.append(np.array([0.0, -1.0, 0.0]))
    tri += [(base, (k + 1) % sides, k) for k in range(sides)]
    return np.asarray(pos, np.float32), np.asarray(tri, np.uint32), np.asarray(nrm, np.float32)
