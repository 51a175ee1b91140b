"""Particle physics against references: XPBD soft bodies, position-based fluids, strands,
rigid coupling, env isolation and health. Small scenes for lavapipe; tolerances in each test."""
import math

import numpy as np
import pytest

import cressim

from .particle_scenes import lattice, open_box, positions, start, static, step, tet_volume, twist_angle


def _beam_sag(make_engine, iterations):
    """Tip sag of a soft cantilever (0.3 x 0.1 x 0.1 m, clamped at x = -0.15) after settling."""
    world = cressim.World(cressim.SceneLayout(1))
    mesh = cressim.TetMesh.box((0.15, 0.05, 0.05), (6, 2, 2))
    rest = mesh.positions
    clamped = np.nonzero(rest[:, 0] < -0.1499)[0]
    beam = world.create_entity(env=0, name="beam")
    beam.add(cressim.Transform(position=(0, 0, 1)))
    beam.add(cressim.SoftBody(mesh, fixed=clamped, mass=0.05, distance_compliance=0.1, volume_compliance=0.1,
                              damping=10.0))
    engine = start(world, make_engine, substeps=4, particle_iterations=iterations)
    step(engine, 60)
    tip = rest[:, 0] > 0.1499
    return 1.0 - positions(engine)[tip, 2].mean()


def test_xpbd_beam_sag_does_not_depend_on_iterations(make_engine):
    # XPBD: a fixed compliance gives one static shape, however many iterations converge it
    sag10, sag40 = _beam_sag(make_engine, 10), _beam_sag(make_engine, 40)
    assert 0.01 < sag40 < 0.1  # it does sag (a soft beam), without folding
    assert abs(sag10 - sag40) / sag40 < 0.05


def test_compressed_soft_cube_keeps_its_volume(make_engine):
    world = cressim.World(cressim.SceneLayout(1))
    static(world, 0, [cressim.Shape.plane()], "ground")
    mesh = cressim.TetMesh.box((0.1, 0.1, 0.1), (4, 4, 4))
    r = 0.0125
    cube = world.create_entity(env=0, name="cube")
    cube.add(cressim.Transform(position=(0, 0, 0.1 + r)))
    cube.add(cressim.SoftBody(mesh, radius=r, distance_compliance=1.0, volume_compliance=0.0, damping=1.0))
    plate = world.create_entity(env=0, name="plate")
    plate.add(cressim.Transform(position=(0, 0, 0.3)))
    plate.add(cressim.RigidBody(kinematic=True))
    plate.add(cressim.Collider(cressim.Shape.box((0.3, 0.3, 0.05))))
    engine = start(world, make_engine, substeps=4, particle_iterations=8)
    v0 = tet_volume(positions(engine), mesh.tets)
    top0 = 0.2 + r
    for f in range(60):  # the plate comes down to squeeze the cube by 20 %
        plate.transform = cressim.Transform(position=(0, 0, max(0.3 - 0.004 * f, 0.8 * top0 + r + 0.05)))
        step(engine, 1)
    p = positions(engine)
    assert p[:, 2].max() < 0.81 * top0  # compressed
    assert p[:, 0].max() - p[:, 0].min() > 0.21  # bulging out
    assert abs(tet_volume(p, mesh.tets) / v0 - 1) < 0.02


def test_settled_fluid_column_keeps_rest_density_and_stays_in(make_engine):
    # Position-based fluid (Macklin & Mueller 2013): 6 x 6 x 8 particles in a box just as wide.
    # Density is checked where the SPH estimate is complete: a kernel support (4 r) away from
    # the walls, the floor and the free surface.
    r, n = 0.025, (6, 6, 8)
    half = n[0] * r
    world = cressim.World(cressim.SceneLayout(1))
    open_box(world, 0, (half + 0.002, half + 0.002), height=1.0)
    water = world.create_entity(env=0, name="water")
    water.add(cressim.Transform())
    water.add(cressim.Fluid(lattice(n, 2 * r, (-half + r, -half + r, r + 0.001)), radius=r, rest_density=1000))
    engine = start(world, make_engine, dt=1 / 240, substeps=1, particle_iterations=4)
    for _ in range(10):  # 1000 steps, escape checked every 100
        step(engine, 100)
        p = positions(engine)
        assert np.all(np.isfinite(p))
        assert np.abs(p[:, :2]).max() <= half + 0.002 and p[:, 2].min() >= 0 and p[:, 2].max() < 1.0
    h = 4 * r
    inner = (np.abs(p[:, 0]) < half - h) & (np.abs(p[:, 1]) < half - h) & (p[:, 2] > h) & (p[:, 2] < p[:, 2].max() - h)
    assert inner.sum() >= 4
    density = engine.buffer("particles.densities").read()
    assert abs(density[inner].mean() / 1000 - 1) < 0.01


def test_particles_meet_colliders_past_the_first_32_of_their_env(make_engine):
    # particle_collider_near keeps a bit for each of an env's first 32 colliders (the ones near a
    # particle this substep); any beyond are visited every time. Here the floor is the 41st.
    r = 0.025
    world = cressim.World(cressim.SceneLayout(1))
    far = [cressim.Shape.sphere(0.01, position=(5 + 0.1 * k, 5, 5)) for k in range(40)]
    static(world, 0, far + [cressim.Shape.plane()])
    water = world.create_entity(env=0, name="water")
    water.add(cressim.Transform())
    water.add(cressim.Fluid(lattice((3, 3, 3), 2 * r, (0, 0, 0.1)), radius=r, rest_density=1000))
    engine = start(world, make_engine, dt=1 / 240, substeps=1, particle_iterations=4)
    step(engine, 120)
    p = positions(engine)
    assert np.all(np.isfinite(p))
    assert p[:, 2].min() > 0.5 * r  # on the floor, not through it
    assert p[:, 2].max() < 0.1  # and settled there


def _catenary(span, length):
    """a of y = a cosh(x / a) through (+-span/2) with arc length `length` (bisection)."""
    lo, hi = 1e-3, 100.0
    for _ in range(200):
        a = 0.5 * (lo + hi)
        lo, hi = (a, hi) if 2 * a * math.sinh(span / (2 * a)) > length else (lo, a)
    return a


def test_hanging_thread_settles_to_a_catenary(make_engine):
    span, count, seg = 0.4, 21, 0.025  # 0.5 m of thread between two points 0.4 m apart
    x = np.linspace(-span / 2, span / 2, count)
    pts = np.stack([x, np.zeros(count), np.full(count, 1.0)], 1) * [1, 1, 1]
    # start as a shallow V of the right length, so the strand is not stretched at rest
    drop = math.sqrt((count // 2 * seg) ** 2 - (span / 2) ** 2)
    pts[:, 2] = 1.0 - drop * (1 - np.abs(x) / (span / 2))
    world = cressim.World(cressim.SceneLayout(1))
    thread = world.create_entity(env=0, name="thread")
    thread.add(cressim.Strand(pts, fixed=[0, count - 1], mass=0.001, bend_compliance=1e3, damping=5.0))
    engine = start(world, make_engine, substeps=4, particle_iterations=8)
    step(engine, 150)
    p = positions(engine)
    length = np.linalg.norm(np.diff(p, axis=0), axis=1).sum()
    assert abs(length / (seg * (count - 1)) - 1) < 0.01  # inextensible within 1 %
    a = _catenary(span, length)
    expected = 1.0 + a * (np.cosh(p[:, 0] / a) - np.cosh(span / (2 * a)))
    assert np.abs(p[:, 2] - expected).max() < 0.01 * span  # within 1 % of the span
    assert np.abs(p[:, 1]).max() < 1e-4  # stays in its plane


def _two_env_trajectory(make_engine, with_env1):
    world = cressim.World(cressim.SceneLayout(2))
    r = 0.025
    for env in range(2 if with_env1 else 1):
        open_box(world, env, (0.1, 0.1), height=0.6)
        water = world.create_entity(env=env, name="water")
        water.add(cressim.Transform())
        # env 1 differs, but its particles are at the same places: same cells, same buckets
        water.add(cressim.Fluid(lattice((4, 4, 3 + env), 2 * r, (-0.075, -0.075, 0.2)), radius=r, vorticity=0.01))
        cube = world.create_entity(env=env, name="cube")
        cube.add(cressim.Transform(position=(0, 0, 0.5 + 0.1 * env)))
        cube.add(cressim.SoftBody(cressim.TetMesh.box((0.05, 0.05, 0.05), (2, 2, 2)), radius=0.025, self_collision=True))
    if not with_env1:
        world.create_entity(env=1, name="empty")
    engine = start(world, make_engine, substeps=2, particle_iterations=2)
    n0 = engine.particle_mapping["env_count"][0]
    out = []
    for _ in range(30):
        step(engine, 1)
        out.append(engine.buffer("particles.positions").read()[:n0].copy())
    return np.array(out)


def test_envs_never_affect_each_other(make_engine):
    alone, beside = _two_env_trajectory(make_engine, False), _two_env_trajectory(make_engine, True)
    assert np.abs(alone[-1] - alone[0]).max() > 0.05  # things moved
    assert np.array_equal(alone, beside)  # bit for bit


def _attached_scene(make_engine, envs=1):
    world = cressim.World(cressim.SceneLayout(envs))
    tools, first = [], []
    for env in range(envs):
        tool = world.create_entity(env=env, name="tool")
        tool.add(cressim.Transform(position=(0, 0, 1)))
        tool.add(cressim.RigidBody(kinematic=True))
        tool.add(cressim.Collider(cressim.Shape.sphere(0.02), group=0, mask=0))
        tools.append(tool)
        blob = world.create_entity(env=env, name="tissue")
        blob.add(cressim.Transform(position=(0, 0, 0.9)))
        blob.add(cressim.SoftBody(cressim.TetMesh.box((0.05, 0.05, 0.05), (2, 2, 2)), mass=0.01,
                                  distance_compliance=1e-3))
    engine = start(world, make_engine, substeps=4, particle_iterations=4)
    m = engine.particle_mapping
    for env in range(envs):
        # the particle at the top centre of the blob
        rest = positions(engine)[m["env_offset"][env]:m["env_offset"][env] + m["env_count"][env]]
        first.append(int(m["env_offset"][env] + np.argmax(rest[:, 2] - np.abs(rest[:, 0]) - np.abs(rest[:, 1]))))
    return world, engine, tools, first


def test_attached_particle_follows_a_moving_kinematic_body(make_engine):
    world, engine, (tool,), (p,) = _attached_scene(make_engine)
    engine.attach_particle(env=0, slot=0, particle=p, body=tool)
    step(engine, 1)  # attached where it is at that step
    offset = positions(engine)[p] - engine.buffer("rigid.positions").read()[0, :3]
    assert abs(offset[2] + 0.05) < 0.01
    worst = 0.0
    for f in range(90):
        target = np.array([0.2 * math.sin(f / 15), 0.1 * math.cos(f / 20), 1.0 + 0.1 * math.sin(f / 10)])
        tool.transform = cressim.Transform(position=tuple(target))
        step(engine, 1)
        body = engine.buffer("rigid.positions").read()[0, :3]
        worst = max(worst, float(np.linalg.norm(positions(engine)[p] - (body + offset))))
    assert worst < 1e-3
    # released, it falls away from the tool
    engine.release_particle(env=0, slot=0)
    step(engine, 30)
    assert positions(engine)[p, 2] < engine.buffer("rigid.positions").read()[0, 2] + offset[2] - 0.05


def test_an_exploding_env_is_flagged_and_reset_alone(make_engine):
    world, engine, tools, first = _attached_scene(make_engine, envs=2)
    start0 = positions(engine)
    engine.attach_particle(env=1, slot=0, particle=first[1], body=tools[1])
    step(engine, 2)
    tools[1].transform = cressim.Transform(position=(50.0, 0, 1))  # yanks its particle at 3 km/s
    step(engine, 1)
    assert list(engine.buffer("env.health").read()) == [0, 2]  # HEALTH_SPEED in env 1 only
    assert engine.health_events == 1
    step(engine, 1)  # reset: env 1 back to its authored state, attachment released
    p = positions(engine)
    n0 = engine.particle_mapping["env_count"][0]
    assert np.all(np.isfinite(p))
    assert np.abs(p[n0:] - start0[n0:]).max() < 0.01
    assert int(engine.buffer("control.particle_attachments").read()[1 * 4, 2]) == 0  # free
    assert engine.health_events == 1


def test_gmsh_files_load(tmp_path):
    # one unit cube split into 5 tets, in both ASCII formats
    nodes = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0), (0, 0, 1), (1, 0, 1), (0, 1, 1), (1, 1, 1)]
    tets = [(1, 2, 4, 6), (1, 4, 3, 7), (1, 6, 5, 7), (4, 6, 7, 8), (1, 4, 7, 6)]
    v2 = ["$MeshFormat", "2.2 0 8", "$EndMeshFormat", "$Nodes", str(len(nodes))]
    v2 += [f"{i + 1} {x} {y} {z}" for i, (x, y, z) in enumerate(nodes)] + ["$EndNodes", "$Elements", str(len(tets) + 1)]
    v2 += ["1 15 2 0 1 1"] + [f"{i + 2} 4 2 0 1 {a} {b} {c} {d}" for i, (a, b, c, d) in enumerate(tets)]
    v2 += ["$EndElements"]
    v4 = ["$MeshFormat", "4.1 0 8", "$EndMeshFormat", "$Nodes", f"1 {len(nodes)} 1 {len(nodes)}", f"3 1 0 {len(nodes)}"]
    v4 += [str(i + 1) for i in range(len(nodes))] + [f"{x} {y} {z}" for x, y, z in nodes] + ["$EndNodes"]
    v4 += ["$Elements", f"1 {len(tets)} 1 {len(tets)}", f"3 1 4 {len(tets)}"]
    v4 += [f"{i + 1} {a} {b} {c} {d}" for i, (a, b, c, d) in enumerate(tets)] + ["$EndElements"]
    for name, lines in (("v2.msh", v2), ("v4.msh", v4)):
        path = tmp_path / name
        path.write_text("\n".join(lines) + "\n")
        mesh = cressim.TetMesh.load(str(path))
        assert mesh.positions.shape == (8, 3) and mesh.tets.shape == (5, 4)
        assert mesh.triangles.shape == (12, 3)  # two per cube face
        assert tet_volume(mesh.positions, mesh.tets) == pytest.approx(1.0)
    with pytest.raises(ValueError, match="no 4-node tetrahedra"):
        (tmp_path / "bad.msh").write_text("\n".join(v2[:13] + ["$EndNodes"]) + "\n")
        cressim.TetMesh.load(str(tmp_path / "bad.msh"))


def test_tetrahedralisers_make_closed_positive_meshes():
    box = cressim.TetMesh.box((0.1, 0.2, 0.3), (2, 3, 4))
    assert tet_volume(box.positions, box.tets) == pytest.approx(0.2 * 0.4 * 0.6, rel=1e-5)
    cyl = cressim.TetMesh.cylinder(0.1, 0.2, 8, 4)
    for mesh in (box, cyl):
        p, t = mesh.positions, mesh.tets
        a, b, c, d = (p[t[:, k]] for k in range(4))
        assert (np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a)) > 0).all()
        # closed surface: the divergence theorem gives the tets' volume back
        f = mesh.triangles
        surface_volume = np.einsum("ij,ij->i", p[f[:, 0]], np.cross(p[f[:, 1]], p[f[:, 2]])).sum() / 6
        assert surface_volume == pytest.approx(tet_volume(p, t), rel=1e-5)


def test_meshfree_soft_body_ties_neighbours():
    world = cressim.World(cressim.SceneLayout(1))
    blob = world.create_entity(env=0, name="blob")
    blob.add(cressim.SoftBody(lattice((3, 3, 3), 0.05), neighbors=6))
    engine = cressim.Engine(world)
    engine.prepare()
    engine.upload_world()
    m = engine.particle_mapping["constraints"]
    assert m["volume"]["object_count"][0] == 0
    assert m["distance"]["object_count"][0] >= 27 * 6 // 2


def test_authoring_errors_name_the_entity(make_engine):
    world = cressim.World(cressim.SceneLayout(2))
    e = world.create_entity(env=1, name="liver")
    e.add(cressim.SoftBody(np.zeros((4, 3)) + np.eye(4, 3), tets=[[0, 1, 2, 7]]))
    with pytest.raises(ValueError, match=r"entity 0 'liver' in env 1: SoftBody.tets names particle 7 of 4"):
        make_engine(world).prepare()
    world = cressim.World(cressim.SceneLayout(1))
    world.create_entity(env=0, name="water").add(cressim.Fluid(np.zeros((3, 3)), budget=2))
    with pytest.raises(ValueError, match="'water' in env 0: Fluid.budget 2 is below its 3 positions"):
        make_engine(world).prepare()
    with pytest.raises(ValueError, match=r"Strand points: give an \(n, 3\) array"):
        cressim.Strand(np.zeros((4, 2)))


def test_fluid_emitter_fills_its_budget_without_reallocation(make_engine):
    world = cressim.World(cressim.SceneLayout(2))
    for env in range(2):
        open_box(world, env, (0.15, 0.15), height=0.6)
        tap = world.create_entity(env=env, name="tap")
        tap.add(cressim.Transform(position=(0, 0, 0.4)))
        tap.add(cressim.Fluid(np.zeros((0, 3)), budget=100, radius=0.02, emit_rate=8, emit_width=3,
                              emit_velocity=(0, 0, -2.5)))
    engine = start(world, make_engine, substeps=2, particle_iterations=3)
    active = lambda: (engine.buffer("particles.phases").read()[:, 3] & 1).reshape(2, -1).sum(1)  # noqa: E731
    step(engine, 1)
    assert list(active()) == [8, 8]
    step(engine, 14)
    assert list(active()) == [100, 100]  # the budget, then no more
    p = positions(engine)
    assert np.abs(p[:, :2]).max() <= 0.15 and p[:, 2].min() >= 0  # fell into the box
    engine.reset_envs([1])
    step(engine, 1)
    assert list(active()) == [100, 8]  # env 1 starts over: its slots inactive, then one frame of emission


def test_strand_self_collision_is_off_unless_asked(make_engine):
    # a coil of three turns stacked on one circle falls onto the ground: its turns pass through
    # each other unless self-collision is on (then no two non-neighbours come closer than 2 r)
    n, r = 60, 0.01
    t = np.linspace(0, 6 * np.pi, n)
    coil = np.stack([0.05 * np.cos(t), 0.05 * np.sin(t), np.full(n, 0.3)], 1)
    closest = {}
    for self_collision in (False, True):
        world = cressim.World(cressim.SceneLayout(1))
        static(world, 0, [cressim.Shape.plane()], "ground")
        world.create_entity(env=0, name="thread").add(cressim.Strand(
            coil, radius=r, mass=0.001, bend_compliance=10.0, damping=1.0, self_collision=self_collision))
        engine = start(world, make_engine, particle_iterations=8)
        step(engine, 60)
        p = positions(engine)
        apart = np.abs(np.arange(n)[:, None] - np.arange(n)[None]) > 2
        closest[self_collision] = np.linalg.norm(p[:, None] - p[None], axis=-1)[apart].min()
    assert closest[False] < r  # overlapping turns
    assert closest[True] > 2 * r * 0.9  # kept apart (10 % slack for the last iteration's residual)


def test_strand_twist_relaxes(make_engine):
    # a straight cable (no gravity) twisted by 90 deg end to end, ends free: the bend-twist
    # constraints untwist it, and the centreline stays straight and keeps its length
    n = 21
    pts = np.stack([np.linspace(0, 0.5, n), np.zeros(n), np.full(n, 1.0)], 1)
    world = cressim.World(cressim.SceneLayout(1))
    world.create_entity(env=0, name="cable").add(cressim.Strand(
        pts, mass=0.001, radius=0.005, initial_twist=math.pi / 2, twist_compliance=1e-3, damping=2.0))
    engine = start(world, make_engine, particle_iterations=8, gravity=(0, 0, 0))
    q = engine.buffer("particles.orientations").read()
    assert q.shape == (n - 1, 4) and twist_angle(q[0], q[-1]) == pytest.approx(math.pi / 2, abs=1e-5)
    step(engine, 30)
    q = engine.buffer("particles.orientations").read()
    assert abs(twist_angle(q[0], q[-1])) < math.radians(1)  # from 90 deg to under 1 deg in 0.5 s
    p = positions(engine)
    assert np.abs(p[:, 1]).max() < 1e-4 and np.abs(p[:, 2] - 1).max() < 1e-4
    assert np.linalg.norm(np.diff(p, axis=0), axis=1).sum() == pytest.approx(0.5, rel=1e-3)


def test_particles_push_dynamic_bodies_back(make_engine):
    # a 0.2 kg box dropped on a soft cube rests on it (one-way, it would fall through to the ground)
    world = cressim.World(cressim.SceneLayout(1))
    static(world, 0, [cressim.Shape.plane()], "ground")
    r = 0.025
    cube = world.create_entity(env=0, name="cube")
    cube.add(cressim.Transform(position=(0, 0, 0.1 + r)))
    cube.add(cressim.SoftBody(cressim.TetMesh.box((0.1, 0.1, 0.1), (4, 4, 4)), radius=r, mass=0.01,
                              distance_compliance=0.01, volume_compliance=0.0, damping=1.0))
    box = world.create_entity(env=0, name="box")
    box.add(cressim.Transform(position=(0, 0, 0.4)))
    box.add(cressim.RigidBody(mass=0.2))
    box.add(cressim.Collider(cressim.Shape.box((0.06, 0.06, 0.06))))
    engine = start(world, make_engine, substeps=4, particle_iterations=8)
    step(engine, 60)
    track = []
    for _ in range(30):  # the last half second
        step(engine, 1)
        track.append(engine.buffer("rigid.positions").read()[0, :3].copy())
    track = np.array(track)
    top = positions(engine)[:, 2].max()
    assert top > 0.2  # the cube holds (squeezed by less than a fifth)
    assert abs(track[-1, 2] - (top + r + 0.06)) < 0.01  # the box lies on it
    assert np.ptp(track[:, 2]) < 0.005 and np.abs(track[:, :2]).max() < 0.01  # and stays put (5 mm, 1 cm)
