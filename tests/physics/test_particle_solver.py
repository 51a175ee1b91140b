"""The constraint solve's two schedules and the contact iteration split: the one-workgroup-per-env
solve (group memory, all colours in one dispatch) must give the per-colour dispatches' result, and
solving contacts in fewer iterations than the constraints must keep a resting body on the ground."""
import numpy as np
import pytest

import cressim

from .particle_scenes import lattice, open_box, positions, start, static, step


def _passes_of_a_frame(engine):
    """The compute passes one frame of `engine` ran, by name."""
    engine.profiling = engine.profile_passes = True
    step(engine, 1)
    engine.profiling = engine.profile_passes = False
    return {name for _, name, _ in engine.last_pass_timings}


def _neighbor_lists(engine):
    """Each particle's neighbour list of the last substep, its entries in order."""
    counts = engine.buffer("particles.neighbor_counts").read().astype(np.int64)
    lists = engine.buffer("particles.neighbor_lists").read()
    assert counts.max() > 1, "the particles had neighbours"
    return [tuple(lists[:c, i]) for i, c in enumerate(counts)]


_GRID_PASSES = ("grid_count", "scan_local", "scan_blocks", "scan_add", "grid_scatter", "grid_sort", "neighbor_list")


def _soft_scene(envs=2, cells=3):
    """A self-colliding soft cube dropped on the ground and a hanging thread, per env."""
    world = cressim.World(cressim.SceneLayout(envs))
    mesh = cressim.TetMesh.box((0.1, 0.1, 0.1), (cells,) * 3)
    for env in range(envs):
        static(world, env, [cressim.Shape.plane()], "ground")
        cube = world.create_entity(env=env, name="cube")
        cube.add(cressim.Transform(position=(0.02 * env, 0, 0.15)))
        cube.add(cressim.SoftBody(mesh, radius=0.02, mass=0.01, distance_compliance=1e-3, volume_compliance=1e-3,
                                  damping=0.5, self_collision=True))
        thread = world.create_entity(env=env, name="thread")
        thread.add(cressim.Transform(position=(0.5, 0, 0.6)))
        thread.add(cressim.Strand(lattice((8, 1, 1), 0.04), fixed=[0], radius=0.01, bend_compliance=1e-3))
    return world, mesh


@pytest.mark.parametrize("cells, build", [(3, 256), (6, 512), (9, 1024)])
def test_workgroup_solve_matches_per_colour_dispatches(make_engine, cells, build):
    """Each group-memory size of the workgroup build, taken as the smallest that holds an env (cube
    and thread: 72, 351 and 1,008 particles); cells 9 has colours of more records than the
    workgroup has threads."""
    frames = 30 if cells == 3 else 10
    runs = {}
    for solver in ("dispatch", "workgroup"):
        world, _ = _soft_scene(cells=cells)
        engine = start(world, make_engine, substeps=2, particle_iterations=6, particle_solver=solver)
        before = positions(engine)
        solves = {name for name in _passes_of_a_frame(engine) if "particle_volume" in name}
        assert solves == ({f"physics/particle_volume.block{build}"} if solver == "workgroup" else
                          {"physics/particle_volume"}), solves
        step(engine, frames - 1)
        runs[solver] = positions(engine)
    assert np.abs(runs["dispatch"] - before).max() > 0.05  # the cube fell and the thread swung
    # same colours in the same order; only floating-point contraction may differ between the builds
    np.testing.assert_allclose(runs["workgroup"], runs["dispatch"], atol=1e-5)


def _pushed_cube(envs=2):
    """SoftBodyPush in small, per env: a self-colliding soft cube on a ground box and a kinematic
    capsule that will push it. Nothing else acts between two iterations, so the workgroup schedule
    runs a substep's iterations, contacts and colliders in one dispatch (particle_iterations)."""
    world = cressim.World(cressim.SceneLayout(envs))
    mesh = cressim.TetMesh.box((0.05, 0.05, 0.05), (3, 3, 3))
    pushers = []
    for env in range(envs):
        static(world, env, [cressim.Shape.box((0.5, 0.5, 0.05), position=(0, 0, -0.05))], "ground")
        cube = world.create_entity(env=env, name="cube")
        cube.add(cressim.Transform(position=(0.01 * env, 0, 0.08)))
        cube.add(cressim.SoftBody(mesh, radius=0.02, mass=0.01, distance_compliance=1e-3, volume_compliance=1e-3,
                                  damping=0.5, self_collision=True))
        pusher = world.create_entity(env=env, name="pusher")
        pusher.add(cressim.Transform(position=(-0.12, 0, 0.06)))
        pusher.add(cressim.RigidBody(kinematic=True))
        pusher.add(cressim.Collider([cressim.Shape.capsule(0.03, 0.05)]))
        pushers.append(pusher)
    return world, mesh, pushers


def test_a_substeps_iterations_in_one_workgroup_match_the_passes(make_engine):
    """The pushed cube in both schedules: per-colour dispatches and the one-dispatch-a-substep
    build (particle_iterations.block256), with 4 contact iterations in 8 (the families' passes
    between them), a particle held by env 1's pusher, a cut made mid-run in env 0, and the force on
    each pusher."""
    runs = {}
    for solver in ("dispatch", "workgroup"):
        world, mesh, pushers = _pushed_cube()
        engine = start(world, make_engine, substeps=2, particle_iterations=8, particle_contact_iterations=4,
                       particle_solver=solver)
        before = positions(engine)
        names = _passes_of_a_frame(engine)
        fused = {name for name in names if "particle_iterations" in name}
        assert fused == ({"physics/particle_iterations.block256"} if solver == "workgroup" else set()), names
        if solver == "workgroup":  # nothing of the iterations left outside it
            assert not {n for n in names if "volume" in n or "distance" in n or n.endswith(("neighbors", "gather", "attach"))}, names
        forces = []
        for f in range(40):
            if f == 20:  # the edges crossing the cube's middle plane, in env 0
                rec = engine.buffer("particles.distance_constraints").read()[:, :2].astype(np.int64)
                rest = engine.buffer("particles.initial_positions").read()[:, 0]
                n = len(mesh.positions)
                crossing = np.nonzero((rec[:, 0] < n) & (rec[:, 1] < n) & ((rest[rec[:, 0]] > 0) != (rest[rec[:, 1]] > 0)))[0]
                assert len(crossing) > 0
                engine.cut_constraints("distance", crossing)
            if f == 10:  # env 1's particle nearest its pusher held by it (the attachment slots)
                n = len(mesh.positions)
                p1 = positions(engine)[n:2 * n]
                near = n + int(np.argmin(np.linalg.norm(p1 - [-0.12 + 0.04 + 0.01, 0, 0.06], axis=1)))
                engine.attach_particle(env=1, slot=0, particle=near, body=pushers[1])
            for env, pusher in enumerate(pushers):
                pusher.transform = cressim.Transform(position=(-0.12 + 0.004 * f + 0.01 * env, 0, 0.06))
            step(engine, 1)
            forces.append(engine.buffer("rigid.contact_forces").read()[:, :3].copy())
        runs[solver] = positions(engine)
        runs[solver + " forces"] = np.array(forces)
    moved = runs["dispatch"] - before
    assert moved[:, 0].max() > 0.02, "the pushers moved the cubes along x"
    assert np.abs(runs["dispatch forces"]).max() > 0.01, "and felt them"
    # the same arithmetic in the same order (lavapipe gives the same bits; the GPU may contract
    # differently); leaving out the attachment moves the cubes by 4e-4 m
    np.testing.assert_allclose(runs["workgroup"], runs["dispatch"], atol=2e-5)
    np.testing.assert_allclose(runs["workgroup forces"], runs["dispatch forces"], atol=1e-3 * np.abs(runs["dispatch forces"]).max())


def test_a_fluids_iterations_in_one_workgroup_match_the_passes(make_engine):
    """Fluid alone in an open box, stirred by a kinematic paddle, two envs: the per-pass schedule
    against particle_fluid_iterations.block256 (density, corrections, the walls' density, the
    colliders and an attachment, a thread a particle)."""
    r = 0.025
    runs = {}
    for solver in ("dispatch", "workgroup"):
        world = cressim.World(cressim.SceneLayout(2))
        paddles = []
        for env in range(2):
            open_box(world, env, (0.2, 0.2), height=0.4)
            water = world.create_entity(env=env, name="water")
            water.add(cressim.Transform())
            water.add(cressim.Fluid(lattice((5, 8, 4), 2 * r, (-0.05 + r + 0.002 * env, -0.2 + r, r + 0.001)), radius=r))
            paddle = world.create_entity(env=env, name="paddle")
            paddle.add(cressim.Transform(position=(-0.12, 0, 0.07)))
            paddle.add(cressim.RigidBody(kinematic=True))
            paddle.add(cressim.Collider([cressim.Shape.box((0.01, 0.1, 0.06))]))
            paddles.append(paddle)
        engine = start(world, make_engine, particle_solver=solver)
        before = positions(engine)
        names = _passes_of_a_frame(engine)
        runs[solver + " lists"] = _neighbor_lists(engine)  # of a frame from the same start
        fused = {name for name in names if "iterations" in name}
        assert fused == ({"physics/particle_fluid_iterations.block256"} if solver == "workgroup" else set()), names
        if solver == "workgroup":  # nothing of the iterations or the neighbour grid left outside it
            assert not {n for n in names if n.endswith(("fluid_lambda", "neighbors", "gather", "attach") + _GRID_PASSES)}, names
        for f in range(20):
            if f == 5:  # env 1's particle nearest its paddle held by it
                n = len(before) // 2
                near = n + int(np.argmin(np.linalg.norm(positions(engine)[n:] - [-0.1, 0, 0.07], axis=1)))
                engine.attach_particle(env=1, slot=0, particle=near, body=paddles[1])
            for env, paddle in enumerate(paddles):
                paddle.transform = cressim.Transform(position=(-0.12 + 0.005 * f, 0, 0.07))
            step(engine, 1)
        runs[solver] = positions(engine)
        runs[solver + " density"] = engine.buffer("particles.densities").read().copy()
        runs[solver + " forces"] = engine.buffer("rigid.contact_forces").read()[:, :3].copy()
    assert np.abs(runs["dispatch"] - before).max() > 0.02, "the water settled and was stirred"
    assert np.abs(runs["dispatch forces"]).max() > 0.01, "and pushed back on the paddles"
    # the same arithmetic in the same order (lavapipe gives the same bits); leaving out the walls'
    # density in the corrections fails this
    np.testing.assert_allclose(runs["workgroup"], runs["dispatch"], atol=2e-5)
    np.testing.assert_allclose(runs["workgroup density"], runs["dispatch density"], rtol=1e-4)
    np.testing.assert_allclose(runs["workgroup forces"], runs["dispatch forces"],
                               atol=1e-3 * np.abs(runs["dispatch forces"]).max())
    # the lists the workgroup builds in group memory are the grid's, entry for entry
    assert runs["workgroup lists"] == runs["dispatch lists"]


def test_workgroup_solve_matches_per_colour_dispatches_for_elastic_tets(make_engine):
    """The elastic vertex solve (particle_tet) in both schedules: a 20 kPa cube dropped on the
    ground, two envs (the second shifted and tilted by its start), contacts inside the solve, and a
    kinematic sphere that the cube lands on the edge of (colliders read from group memory)."""
    runs = {}
    for solver in ("dispatch", "workgroup"):
        world = cressim.World(cressim.SceneLayout(2))
        mesh = cressim.TetMesh.box((0.02, 0.02, 0.02), (3, 3, 3))
        for env in range(2):
            static(world, env, [cressim.Shape.plane()], "ground")
            cube = world.create_entity(env=env, name="cube")
            cube.add(cressim.Transform(position=(0.0, 0.0, 0.03 + 0.01 * env), rotation=(0.0, 0.1 * env, 0.0, 1.0)))
            cube.add(cressim.SoftBody(mesh, youngs_modulus=2e4, poisson_ratio=0.45, density=1000.0, radius=0.003,
                                      damping=1.0))
            tool = world.create_entity(env=env, name="tool")
            tool.add(cressim.Transform(position=(0.02, 0.0, 0.012)))
            tool.add(cressim.RigidBody(kinematic=True))
            tool.add(cressim.Collider([cressim.Shape.sphere(0.01)]))
        engine = start(world, make_engine, substeps=4, particle_iterations=4, particle_solver=solver)
        before = positions(engine)
        step(engine, 30)
        runs[solver] = positions(engine)
        forces = engine.buffer("particles.tet_contact_forces").read()
        runs[solver + " forces"] = forces[:, :3]
        assert (forces[:, 3] > 0).any(), "the cube rests partly on the kinematic sphere"
    assert np.abs(runs["dispatch"] - before).max() > 0.01  # it fell onto the ground
    assert runs["dispatch"][:, 2].min() > 0.0  # and rests on it
    np.testing.assert_allclose(runs["workgroup"], runs["dispatch"], atol=1e-5)
    np.testing.assert_allclose(runs["workgroup forces"], runs["dispatch forces"], atol=1e-4)


def test_contacts_in_fewer_iterations_keep_a_resting_cube_up(make_engine):
    tops = {}
    for contacts in (0, 4):  # 0: all 16 iterations solve contacts
        world, mesh = _soft_scene(envs=1)
        engine = start(world, make_engine, substeps=2, particle_iterations=16, particle_contact_iterations=contacts)
        step(engine, 60)
        p = positions(engine)[: len(mesh.positions)]
        assert p[:, 2].min() > 0.02 - 2e-3, f"cube sank into the ground ({contacts} contact iterations)"
        tops[contacts] = p[:, 2].max()
    assert abs(tops[4] - tops[0]) < 3e-3, tops


def test_particles_substep_at_their_own_rate(make_engine):
    """particle_substeps = 2 under substeps = 8: the particles step exactly as with 2 substeps, a
    falling body exactly as with 8 (they do not touch here)."""
    def run(**settings):
        world, mesh = _soft_scene(envs=1)
        box = world.create_entity(env=0, name="box")
        box.add(cressim.Transform(position=(-0.6, 0, 2.0)))
        box.add(cressim.RigidBody(mass=1.0, inertia=(0.01, 0.01, 0.01)))
        engine = start(world, make_engine, **settings)
        step(engine, 20)
        return positions(engine), engine.buffer("rigid.positions").read()[:, :3].copy()

    split, particles_2, bodies_8 = run(substeps=8, particle_substeps=2), run(substeps=2), run(substeps=8)
    np.testing.assert_array_equal(split[0], particles_2[0])
    np.testing.assert_array_equal(split[1], bodies_8[1])
    assert np.abs(bodies_8[1] - particles_2[1]).max() > 1e-4  # the body's fall depends on its substep
    assert np.abs(split[0] - run(substeps=8)[0]).max() > 1e-5  # and the particles' on theirs


def test_solver_settings_are_checked(make_engine):
    with pytest.raises(ValueError, match="particle_contact_iterations"):
        cressim.PhysicsSettings(particle_iterations=4, particle_contact_iterations=5)
    with pytest.raises(ValueError, match="'gpu' is not one of auto, dispatch, workgroup"):
        cressim.PhysicsSettings(particle_solver="gpu")
    with pytest.raises(ValueError, match="particle_substeps: must be 0..256"):
        cressim.PhysicsSettings(particle_substeps=257)
    world = cressim.World(cressim.SceneLayout(1))
    big = world.create_entity(env=0, name="big")
    big.add(cressim.Transform(position=(0, 0, 1)))
    big.add(cressim.SoftBody(cressim.TetMesh.box((0.2, 0.2, 0.2), (10, 10, 10))))
    with pytest.raises(ValueError, match="env 0 has 1331"):
        start(world, make_engine, particle_solver="workgroup")
