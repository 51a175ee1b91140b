"""The neighbour lists (particle_neighbor_list): built by several lanes a particle with a ballot,
they must hold exactly what one thread's walk over the 27 cells would, in its order, each entry
marked with the neighbour's kind."""
import itertools

import numpy as np

import cressim

from .particle_scenes import lattice, start, step

FLUID, FLUID_BIT, MAX_NEIGHBORS = 2, 0x80000000, 64


def walk(i, x, cells, reach):
    """One thread's walk: cells dz, dy, dx from -1 to 1 (x fastest), each cell's particles by index."""
    home = cells[i]
    out = []
    for dz, dy, dx in itertools.product((-1, 0, 1), repeat=3):
        cell = home + np.array([dx, dy, dz, 0], np.int32)
        for j in np.flatnonzero((cells == cell).all(axis=1)):
            r = x[j] - x[i]
            if np.dot(r, r) < np.float32(reach) ** 2:
                out.append(int(j))
    return out[:MAX_NEIGHBORS]


def test_lists_hold_the_walk_in_its_order_with_each_neighbours_kind(make_engine):
    # Fluid below rest density (spacing 2.2 r) beside a meshfree soft body, no gravity: nothing
    # moves, so the lists the first frame built can be walked again here. Two envs with the same
    # particles at the same places share the hash table and must never list each other's.
    r = 0.02
    world = cressim.World(cressim.SceneLayout(2))
    for env in range(2):
        water = world.create_entity(env=env, name="water")
        water.add(cressim.Transform())
        water.add(cressim.Fluid(lattice((4, 4, 3), 2.2 * r, (0, 0, 0.5)), radius=r))
        tissue = world.create_entity(env=env, name="tissue")
        tissue.add(cressim.Transform())
        tissue.add(cressim.SoftBody(lattice((3, 3, 2), 0.03, (3 * 2.2 * r + 0.045, 0, 0.5)), radius=r))
    engine = start(world, make_engine, gravity=(0, 0, 0), dt=1 / 240, substeps=1, particle_iterations=2)
    authored = engine.buffer("particles.positions").read()[:, :3].copy()
    step(engine, 1)
    x = engine.buffer("particles.positions").read()[:, :3].astype(np.float32)
    np.testing.assert_allclose(x, authored, atol=1e-6)  # the premise: nothing moved
    cells = engine.buffer("particles.cells").read().astype(np.int32)
    kinds = engine.buffer("particles.phases").read()[:, 0]
    counts = engine.buffer("particles.neighbor_counts").read()
    lists = engine.buffer("particles.neighbor_lists").read()
    reach = 1.05 * 4 * r  # the cell: the fluid kernel's support
    mixed = 0
    for i in range(len(x)):
        entries = lists[: counts[i], i].astype(np.int64)
        listed = (entries & ~FLUID_BIT).tolist()
        assert listed == walk(i, x, cells, reach), f"particle {i}"
        assert np.array_equal((entries & FLUID_BIT) != 0, kinds[listed] == FLUID), f"particle {i}"
        assert np.all(cells[listed, 3] == cells[i, 3]), f"particle {i} lists another env's"
        mixed += len(set(kinds[listed].tolist())) > 1
    assert mixed > 0  # some particles list both kinds
    assert counts.max() > 8  # more candidates than two rounds of lanes
