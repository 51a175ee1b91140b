"""Elastic soft bodies in physical units (Young's modulus, Poisson's ratio, density) against an
independent finite element reference (scikit-fem, fem_reference.py) on the same tet mesh, at the
default solver settings and at two resolutions; the static shape does not follow the iteration
count. Each scene settles under gravity with a little velocity damping (it does not change the
static shape) and is measured after 3 s of simulated time."""
import numpy as np
import pytest

import cressim

from .fem_reference import static_displacement
from .particle_scenes import positions, start, static, step

DENSITY = 1000.0
SETTLE_FRAMES = 180  # 3 s at the default 60 Hz


def _settle(make_engine, mesh, clamped, youngs_modulus, poisson_ratio, **settings):
    """Static displacement of every particle of a body clamped where `clamped` says."""
    world = cressim.World(cressim.SceneLayout(1))
    rest = np.asarray(mesh.positions, dtype=np.float64)
    body = world.create_entity(env=0, name="tissue")
    body.add(cressim.Transform(position=(0, 0, 1)))
    body.add(cressim.SoftBody(mesh, fixed=np.nonzero(clamped(rest.T))[0], youngs_modulus=youngs_modulus,
                              poisson_ratio=poisson_ratio, density=DENSITY, damping=5.0))
    engine = start(world, make_engine, **settings)
    step(engine, SETTLE_FRAMES)
    return positions(engine) - (rest + [0, 0, 1]), rest


def _reference(mesh, rest, clamped, youngs_modulus, poisson_ratio):
    return static_displacement(rest, np.asarray(mesh.tets), clamped, youngs_modulus, poisson_ratio, DENSITY)


# (half extents, clamped axis, E, nu, the reference's expected range, m): a 60 x 30 x 30 mm, 100 kPa
# cantilever clamped at x = -30 mm sags about 2 mm at its tip; a 20 x 20 x 80 mm column of 20 kPa
# tissue (nu 0.45, the default) on its clamped base drops about 1.5 mm at its top (small strain)
SCENES = {"cantilever": ((0.03, 0.015, 0.015), 0, 1e5, 0.3, (1e-3, 4e-3)),
          "column": ((0.01, 0.01, 0.04), 2, 2e4, 0.45, (5e-4, 3e-3))}


@pytest.mark.parametrize("scene, cells", [("cantilever", (8, 2, 2)), ("cantilever", (16, 4, 4)),
                                          ("column", (2, 2, 8)), ("column", (4, 4, 16))])
def test_static_shape_matches_the_fem_reference(make_engine, scene, cells):
    half, axis, youngs_modulus, poisson_ratio, expected = SCENES[scene]
    mesh = cressim.TetMesh.box(half, cells)

    def clamped(x):
        return x[axis] < -half[axis] + 1e-6

    u, rest = _settle(make_engine, mesh, clamped, youngs_modulus, poisson_ratio)
    ref = _reference(mesh, rest, clamped, youngs_modulus, poisson_ratio)
    free_end = rest[:, axis] > half[axis] - 1e-6  # the tip, or the top
    drop, ref_drop = -u[free_end, 2].mean(), -ref[free_end, 2].mean()
    assert expected[0] < ref_drop < expected[1]
    assert abs(drop - ref_drop) / ref_drop < 0.05, (drop, ref_drop)


def test_stiffness_does_not_follow_the_iteration_count(make_engine):
    mesh = cressim.TetMesh.box((0.03, 0.015, 0.015), (8, 2, 2))

    def clamped(x):
        return x[0] < -0.03 + 1e-6

    tip = np.asarray(mesh.positions)[:, 0] > 0.03 - 1e-6
    sags = [-_settle(make_engine, mesh, clamped, 1e5, 0.3, particle_iterations=n)[0][tip, 2].mean() for n in (1, 8)]
    assert abs(sags[0] - sags[1]) / sags[1] < 0.02, sags


@pytest.mark.parametrize("cells", [2, 4])
def test_a_block_resting_on_a_floor_matches_the_fem_reference(make_engine, cells):
    """Held by contacts instead of clamped particles: a 40 mm cube of 20 kPa tissue on a
    frictionless floor against the same mesh on a sliding support; at 1 and 4 iterations."""
    mesh = cressim.TetMesh.box((0.02, 0.02, 0.02), (cells,) * 3)
    rest = np.asarray(mesh.positions, dtype=np.float64)
    ref = static_displacement(rest, np.asarray(mesh.tets), lambda x: x[2] < -0.02 + 1e-6, 2e4, 0.45, DENSITY,
                              sliding=True)
    top = rest[:, 2] > 0.02 - 1e-6
    ref_drop = -ref[top, 2].mean()
    assert 3e-4 < ref_drop < 5e-4  # rho g H^2 / 2E = 0.39 mm (uniaxial)
    radius = 0.002
    for iterations in (1, 4):
        world = cressim.World(cressim.SceneLayout(1))
        static(world, 0, [cressim.Shape.plane()], "floor")
        block = world.create_entity(env=0, name="tissue")
        block.add(cressim.Transform(position=(0, 0, 0.02 + radius)))  # particle spheres touch the floor
        block.add(cressim.SoftBody(mesh, youngs_modulus=2e4, poisson_ratio=0.45, density=DENSITY, radius=radius,
                                   friction=0.0, damping=5.0))
        engine = start(world, make_engine, particle_iterations=iterations)
        step(engine, SETTLE_FRAMES)
        drop = 0.04 + radius - positions(engine)[top, 2].mean()
        assert abs(drop - ref_drop) / ref_drop < 0.05, (iterations, drop, ref_drop)


def test_mass_is_density_times_volume(make_engine):
    world = cressim.World(cressim.SceneLayout(1))
    for k, cells in enumerate(((2, 2, 2), (5, 5, 5))):
        world.create_entity(env=0, name=f"block{k}").add(
            cressim.SoftBody(cressim.TetMesh.box((0.02, 0.03, 0.04), cells), density=1060.0))
    engine = start(world, make_engine)
    inv_mass = engine.buffer("particles.positions").read()[:, 3]
    first = 27  # the coarse block's particles come first
    for part in (inv_mass[:first], inv_mass[first:]):
        assert (1 / part).sum() == pytest.approx(1060.0 * 0.04 * 0.06 * 0.08, rel=1e-5)


def test_material_values_are_checked(make_engine):
    mesh = cressim.TetMesh.box((0.01, 0.01, 0.01), (1, 1, 1))
    with pytest.raises(ValueError, match="either youngs_modulus .* or compliances"):
        cressim.SoftBody(mesh, youngs_modulus=1e4, distance_compliance=1e-3)
    with pytest.raises(ValueError, match="mass comes from density"):
        cressim.SoftBody(mesh, mass=0.01)
    with pytest.raises(ValueError, match="youngs_modulus needs tets"):
        cressim.SoftBody(np.eye(3), youngs_modulus=1e4)
    for field, kwargs in (("poisson_ratio must be in \\[0, 0.5\\)", dict(poisson_ratio=0.5)),
                          ("youngs_modulus must be positive, got nan", dict(youngs_modulus=float("nan"))),
                          ("youngs_modulus must be positive, got -1", dict(youngs_modulus=-1.0)),
                          ("density must be positive, got 0", dict(density=0.0))):
        world = cressim.World(cressim.SceneLayout(2))
        world.create_entity(env=1, name="liver").add(cressim.SoftBody(mesh, **kwargs))
        with pytest.raises(ValueError, match=f"entity 0 'liver' in env 1: SoftBody.{field}"):
            make_engine(world).prepare()


def test_cut_tets_let_the_free_piece_fall(make_engine):
    mesh = cressim.TetMesh.box((0.03, 0.015, 0.015), (8, 2, 2))
    rest = np.asarray(mesh.positions, dtype=np.float64)
    world = cressim.World(cressim.SceneLayout(1))
    beam = world.create_entity(env=0, name="tissue")
    beam.add(cressim.Transform(position=(0, 0, 1)))
    beam.add(cressim.SoftBody(mesh, fixed=np.nonzero(rest[:, 0] < -0.03 + 1e-6)[0], youngs_modulus=1e4))
    # the cut piece shares its body's support measure with the clamped half (per body), so at the
    # defaults it starts each solve partly held and falls at about 3/4 g; 32 substeps resolve it
    # (docs/particles.md, "Elastic tets")
    engine = start(world, make_engine, substeps=32, particle_iterations=2)
    tets = engine.buffer("particles.tet_constraints").read()[:, :4].astype(np.int64)
    x = engine.buffer("particles.positions").read()[:, 0]
    cut = 0.00375  # mid-cell: the tets of the cells it crosses have corners on both sides
    across = np.nonzero((x[tets] < cut).any(axis=1) & (x[tets] > cut).any(axis=1))[0]
    assert len(across) > 0
    engine.cut_constraints("tet", across.tolist())
    step(engine, 30)  # 0.5 s: the free piece falls g t^2 / 2 = 1.2 m (90 % of it at least), the rest hangs
    z = positions(engine)[:, 2]
    assert z[rest[:, 0] > cut].max() < 1.0 - 0.9 * 9.81 * 0.5**2 / 2 + 0.02
    assert abs(z[rest[:, 0] < cut].mean() - 1.0) < 0.01


@pytest.mark.parametrize("youngs_modulus", [1e3, 1e5])
def test_a_free_body_falls_as_a_body_at_the_defaults(make_engine, youngs_modulus):
    world = cressim.World(cressim.SceneLayout(1))
    block = world.create_entity(env=0, name="tissue")
    block.add(cressim.Transform(position=(0, 0, 10)))
    block.add(cressim.SoftBody(cressim.TetMesh.box((0.02, 0.02, 0.02), (6, 6, 6)), youngs_modulus=youngs_modulus))
    engine = start(world, make_engine)
    z0 = positions(engine)[:, 2].mean()
    step(engine, 30)
    fallen = z0 - positions(engine)[:, 2].mean()
    # semi-implicit Euler at 240 Hz over 0.5 s: g t^2 / 2 (1 + 1 / steps), within 1 %
    assert fallen == pytest.approx(9.81 * 0.5**2 / 2 * (1 + 1 / 120), rel=0.01)
