"""Ultrasound scatterers carried by a soft body's tets or particles: the image follows the particles.

A tissue on an entity with a tetrahedral SoftBody gets its scatterers inside the tets (barycentric
weights), on a meshfree SoftBody on four nearby particles each (affine weights); inclusions are
judged at the rest positions, so both deform with the tissue.
Checks: at rest the image equals the rigid path's with the same scatterers placed one by one; a
uniform axial compression of the particle positions (the entity's scale, applied to the particles
and not to the rest frame) moves a bright point and a cyst to where the strain puts them (within
a pixel) and shortens the cyst's axial extent by strain x diameter (within two pixels).
"""
import numpy as np
import pytest

import cressim

from .test_ultrasound import FS, MM, C, probe

HALF = (4 * MM, 1.2 * MM, 4 * MM)  # the tissue box, half extents
TOP = 2 * MM                     # depth of its face toward the probe
ROW = 12 * MM / 128              # image pixel height (and width: 14.4 mm over 96)
COL = 96 * 0.15 * MM / 96


def soft_tissue(world, env, scale=1.0, **tissue):
    """The box compressed along the beam by `scale` about its face (which stays at TOP)."""
    mesh = cressim.TetMesh.box(HALF, (4, 2, 4))
    t = world.create_entity(env=env, name="tissue")
    t.add(cressim.Transform(position=(0, 0, TOP + HALF[2] * scale), scale=(1, 1, scale)))
    t.add(cressim.SoftBody(mesh, radius=0.2 * MM))
    t.add(cressim.UltrasoundTissue(**tissue))
    return t


def imaged(make_engine, world):
    engine = make_engine(world)
    engine.physics = cressim.PhysicsSettings(gravity=(0, 0, 0))
    engine.prepare()
    engine.upload_world()
    engine.step_simulation_sensors()
    engine.end_frame()
    iq = engine.buffer("ultrasound0.iq").read()
    return engine, np.hypot(iq[..., 0], iq[..., 1]), engine.buffer("ultrasound0.image").read()


def with_probes(world, envs, **fields):
    for env in range(envs):
        p = world.create_entity(env=env, name="probe")
        p.add(cressim.Transform())
        p.add(probe(**fields))
    return world


def test_soft_tissue_at_rest_images_as_the_rigid_path(make_engine):
    world = cressim.World(cressim.SceneLayout(1))
    # no attenuation: a soft tissue's scatterers lose their own alpha over their whole depth, a
    # rigid tissue's along the media their lines cross (docs/ultrasound.md)
    soft_tissue(world, 0, density=2.5e9, attenuation=0.0, inclusions=[cressim.UltrasoundInclusion((0, 0, 0), 1.5 * MM)])
    engine, soft, soft_image = imaged(make_engine, with_probes(world, 1))
    assert engine.ultrasound_probes["tets"] == 4 * 2 * 4 * 6
    places, amplitudes = scatterer_places(engine)
    assert 300 < len(places) < 460  # 2.5 per mm^3 of 153.6 mm^3, less the cyst's 14.1
    assert (np.linalg.norm(places - (0, 0, TOP + HALF[2]), axis=1) > 1.5 * MM - 1e-6).all()

    rigid = cressim.World(cressim.SceneLayout(1))
    for p, a in zip(places, amplitudes):
        e = rigid.create_entity(env=0, name="scatterer")
        e.add(cressim.Transform(position=tuple(float(c) for c in p)))
        e.add(cressim.UltrasoundTissue(region="sphere", size=(1e-12, 0, 0), count=1, amplitude_mean=float(a),
                                       amplitude_std=0.0, attenuation=0.0))
    _, hard, hard_image = imaged(make_engine, with_probes(rigid, 1))
    print(f"soft vs rigid: envelope max {soft.max():.4f}, largest difference {np.abs(soft - hard).max():.2e}")
    assert np.abs(soft - hard).max() <= 1e-4 * soft.max()
    assert np.abs(soft_image - hard_image).max() <= 1e-3


def scatterer_places(engine):
    """World positions of the scatterers from their tets' particles, and their amplitudes."""
    scatterers = engine.buffer("ultrasound.scatterers").read()
    carrier = engine.buffer("ultrasound.scatterer_carrier").read()
    tets = engine.buffer("ultrasound.tets").read()
    particles = engine.buffer("particles.positions").read()[:, :3]
    assert (carrier[:, 0] & 0x80000000).all()
    corners = particles[tets[carrier[:, 0] & 0x7FFFFFFF]]  # (n, 4, 3)
    w = np.concatenate([1 - scatterers[:, :3].sum(1, keepdims=True), scatterers[:, :3]], axis=1)
    return (w[:, :, None] * corners).sum(1), scatterers[:, 3]


def test_compression_moves_and_shortens_what_the_tissue_carries(make_engine):
    strain, radius, seed = 0.75, 1.2 * MM, 3
    cyst = cressim.UltrasoundInclusion((0, 0, 2 * MM), radius)
    # a point target: in each env the scatterer nearest (1.5, 0, -1.5) mm (rest frame) made 100
    # times brighter. Scatterer positions do not depend on inclusions (the same draws), so a
    # first world without them finds it. count, not density: the compressed tissue keeps its number.
    tissue = dict(count=30000, attenuation=0.0, seed=3)
    scales = (1.0, strain)
    world = cressim.World(cressim.SceneLayout(2))
    for env, scale in enumerate(scales):
        soft_tissue(world, env, scale, **tissue)
    first = make_engine(with_probes(world, 2))
    first.prepare()
    first.upload_world()
    places = scatterer_places(first)[0]
    ranges = first.buffer("ultrasound.env_scatterers").read()
    targets, brights = [], []
    for env, scale in enumerate(scales):
        first_s, n = ranges[env]
        rest = (places[first_s:first_s + n] - (0, 0, TOP + HALF[2] * scale)) / (1, 1, scale)
        target = rest[np.argmin(np.linalg.norm(rest - (1.5 * MM, 0, -1.5 * MM), axis=1))]
        spacing = np.sort(np.linalg.norm(rest - target, axis=1))[1]
        targets.append(target)
        brights.append(cressim.UltrasoundInclusion(tuple(float(c) for c in target), 0.5 * spacing,
                                                   amplitude_scale=100.0))

    world = cressim.World(cressim.SceneLayout(2))
    for env, scale in enumerate(scales):
        soft_tissue(world, env, scale, inclusions=[cyst, brights[env]], **tissue)
    # a thin slice (0.5 mm elevational FWHM, cut at 0.64 mm): the cyst's middle gets no echo at all
    engine, env, image = imaged(make_engine, with_probes(world, 2, elevational_beam_width=0.5 * MM))
    assert (scatterer_places(engine)[1] > 10).sum() == 2  # the point, once in each env
    dz = C / (2 * FS) * 4

    def rest_to_depth(z, scale):  # the entity frame's z (rest) to depth below the probe
        return TOP + (HALF[2] + z) * scale

    extents = []
    for e, img, scale, target in zip(env, image, scales, targets):
        line, sample = np.unravel_index(np.argmax(e), e.shape)
        x, z = (line - 47.5) * 0.15 * MM, (sample + 0.5) * dz
        print(f"strain {scale}: point at ({x / MM:.3f}, {z / MM:.3f}) mm, predicted "
              f"({target[0] / MM:.3f}, {rest_to_depth(target[2], scale) / MM:.3f})")
        assert abs(x - target[0]) <= COL and abs(z - rest_to_depth(target[2], scale)) <= ROW
        # the cyst: dark pixels of the middle columns between the point and the tissue's far face
        rows, _ = np.nonzero(img[:, 40:56] < 0.15)
        centres = (rows + 0.5) * ROW
        rows = rows[(centres > TOP + 3.5 * MM) & (centres < rest_to_depth(HALF[2], scale) - 0.4 * MM)]
        centre = (rows.mean() + 0.5) * ROW
        extents.append((rows.max() - rows.min() + 1) * ROW)
        print(f"strain {scale}: cyst centre {centre / MM:.3f} mm (predicted {rest_to_depth(2 * MM, scale) / MM:.3f}),"
              f" dark axial extent {extents[-1] / MM:.3f} mm")
        assert abs(centre - rest_to_depth(2 * MM, scale)) <= ROW
    # the dark extent is the cyst's less a blur that compression does not change: it shortens
    # by (1 - strain) x the diameter
    shortening = extents[0] - extents[1]
    print(f"cyst shortened by {shortening / MM:.3f} mm (predicted {(1 - strain) * 2 * radius / MM:.3f})")
    assert abs(shortening - (1 - strain) * 2 * radius) <= 2 * ROW


def meshfree_tissue(world, env, scale=1.0, **tissue):
    """The tets' box as a meshfree body: a 9 x 3 x 9 lattice 1 mm apart, each particle standing
    for the 1 mm cube around it (243 mm^3), compressed along the beam by `scale` as above."""
    axes = [np.arange(-k, k + 1) * MM for k in (4, 1, 4)]
    lattice = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    t = world.create_entity(env=env, name="tissue")
    t.add(cressim.Transform(position=(0, 0, TOP + 4.5 * MM * scale), scale=(1, 1, scale)))
    t.add(cressim.SoftBody(lattice, radius=0.2 * MM))
    t.add(cressim.UltrasoundTissue(**tissue))
    return t, lattice


def test_meshfree_tissue_carries_its_scatterers(make_engine):
    """A meshfree SoftBody carries scatterers on four nearby particles each (affine weights): they
    fill the particles' cubes at the tissue's density, stay out of the cyst, follow the particles
    (a squeezed body's scatterers are its rest ones squeezed) and the image's cyst moves with it."""
    radius, scales = 1.5 * MM, (1.0, 0.75)
    world = cressim.World(cressim.SceneLayout(2))
    for env, scale in enumerate(scales):
        _, lattice = meshfree_tissue(world, env, scale, density=2.5e9, attenuation=0.0, seed=5,
                                     inclusions=[cressim.UltrasoundInclusion((0, 0, 0), radius)])
    engine, _, image = imaged(make_engine, with_probes(world, 2, elevational_beam_width=0.5 * MM))
    places, _ = scatterer_places(engine)
    scatterers = engine.buffer("ultrasound.scatterers").read()
    tets = engine.buffer("ultrasound.tets").read()
    carrier = engine.buffer("ultrasound.scatterer_carrier").read()[:, 0] & 0x7FFFFFFF
    offsets = engine.particle_mapping["object_offset"]
    ranges = engine.buffer("ultrasound.env_scatterers").read()
    for env, scale in enumerate(scales):
        first, n = ranges[env]
        # 2.5 per mm^3 of 243 mm^3 less the cyst's 14.1: 572 expected (Poisson sd 24) at rest, and
        # the density holds in the squeezed volume (scale applies, as to the particles)
        assert 480 * scale < n < 660 * scale, n
        sl = slice(first, first + n)
        # the rest place from the same weights on the lattice (the body's own frame)
        corners = lattice[tets[carrier[sl]] - offsets[env]]
        w = np.concatenate([1 - scatterers[sl, :3].sum(1, keepdims=True), scatterers[sl, :3]], axis=1)
        rest = (w[:, :, None] * corners).sum(1)
        # inside the particles' cubes, outside the cyst
        nearest = np.abs(rest[:, None, :] - lattice[None]).max(2).min(1)
        assert (nearest <= 0.5 * MM + 1e-7).all()
        assert (np.linalg.norm(rest, axis=1) > radius - 1e-6).all()
        # carried: where the (squeezed) particles put them
        centre = np.array([0, 0, TOP + 4.5 * MM * scale])
        np.testing.assert_allclose(places[sl], centre + rest * (1, 1, scale), atol=1e-7)
        # the cyst's dark pixels in the middle columns centre on its squeezed depth (within 2 rows)
        rows, _ = np.nonzero(image[env][:, 40:56] < 0.15)
        depths = (rows + 0.5) * ROW
        inside = (depths > TOP + (4.5 * MM - 2.5 * MM) * scale) & (depths < TOP + (4.5 * MM + 2.5 * MM) * scale)
        found = depths[inside].mean()
        print(f"meshfree, scale {scale}: {n} scatterers, cyst at {found / MM:.3f} mm "
              f"(expected {(TOP + 4.5 * MM * scale) / MM:.3f})")
        assert abs(found - (TOP + 4.5 * MM * scale)) <= 2 * ROW


def test_meshfree_tissue_errors_name_the_entity(make_engine):
    world = cressim.World(cressim.SceneLayout(1))
    t = world.create_entity(env=0, name="liver")
    t.add(cressim.SoftBody(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]]) * MM, radius=0.2 * MM))
    t.add(cressim.UltrasoundTissue(density=1e9))
    with pytest.raises(ValueError, match="'liver' in env 0: UltrasoundTissue on a meshfree SoftBody: particles near"):
        make_engine(with_probes(world, 1)).prepare()
