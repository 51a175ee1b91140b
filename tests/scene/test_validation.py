"""prepare() checks every authored field (engine/scene/validate.cpp): each bad value is an
AuthoringError naming the entity, its env and the field, never a value silently replaced or a
NaN the env resets into every frame. A replaced component is applied (Transform) or asks for
prepare() again (any other kind)."""
import math

import numpy as np
import pytest

import cressim

NAN, INF = math.nan, math.inf
SPHERE = cressim.Shape.sphere(0.1)
POINTS = np.array([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0]], np.float32)
BOX = cressim.TetMesh.box((0.1, 0.1, 0.1), (1, 1, 1))


def body(mass=1.0, **kw):
    return [cressim.RigidBody(mass=mass, **kw), cressim.Collider(SPHERE)]


def joint(**kw):
    return [cressim.Joint("hinge", body_b=1, **kw)]  # entity 1 is a rigid body of the same env


def probe(**kw):
    return [cressim.UltrasoundProbe(**kw)]


def tissue(**kw):
    return [cressim.UltrasoundTissue(count=10, **kw)]


# (components of the bad entity, the field named, a piece of the message)
BAD = [
    # Transform
    ([cressim.Transform(position=(NAN, 0, 0))], "Transform.position[0]", "must be finite, got nan"),
    ([cressim.Transform(rotation=(0, INF, 0, 1))], "Transform.rotation[1]", "must be finite, got inf"),
    ([cressim.Transform(rotation=(0, 0, 0, 0))], "Transform.rotation", "non-zero quaternion"),
    ([cressim.Transform(scale=(1, 0, 1))], "Transform.scale[1]", "must not be 0"),
    # RigidBody
    (body(mass=-1), "RigidBody.mass", "must be >= 0 (0: density x the collider shapes' volume), got -1"),
    (body(mass=NAN), "RigidBody.mass", "got nan"),
    (body(mass=0, density=0), "RigidBody.density", "must be positive, got 0"),
    (body(inertia=(1, -1, 1)), "RigidBody.inertia[1]", "must be >= 0, got -1"),
    (body(linear_damping=-0.5), "RigidBody.linear_damping", "must be >= 0, got -0.5"),
    (body(angular_damping=NAN), "RigidBody.angular_damping", "got nan"),
    # Collider
    ([cressim.RigidBody(), cressim.Collider(SPHERE, restitution=5)], "Collider.restitution", "must be in [0, 1], got 5"),
    ([cressim.Collider(SPHERE, static_friction=-1)], "Collider.static_friction", "must be >= 0, got -1"),
    ([cressim.Collider(SPHERE, dynamic_friction=NAN)], "Collider.dynamic_friction", "got nan"),
    ([cressim.Collider(cressim.Shape.sphere(INF))], "Collider.shapes[0].size[0]", "must be finite, got inf"),
    ([cressim.Collider(cressim.Shape.box((0.1, 0, 0.1)))], "Collider.shapes[0].size[1]", "must be positive, got 0"),
    ([cressim.Collider([SPHERE, cressim.Shape.box((0.1, 0.1, 0.1), position=(0, NAN, 0))])],
     "Collider.shapes[1].position[1]", "must be finite"),
    ([cressim.Collider(cressim.Shape.capsule(0.1, 0.2, rotation=(0, 0, 0, 0)))], "Collider.shapes[0].rotation",
     "non-zero quaternion"),
    # Joint
    (joint(anchor=(0, NAN, 0)), "Joint.anchor[1]", "must be finite, got nan"),
    (joint(axis=(INF, 0, 0)), "Joint.axis[0]", "must be finite, got inf"),
    (joint(stiffness=-1, drive="position"), "Joint.stiffness", "must be >= 0, got -1"),
    (joint(damping=-2, drive="velocity"), "Joint.damping", "must be >= 0, got -2"),
    (joint(compliance=NAN), "Joint.compliance", "got nan"),
    (joint(max_force=NAN), "Joint.max_force", "must be >= 0 (inf: unlimited), got nan"),
    (joint(limits=(NAN, 1)), "Joint.lower", "must be finite, got nan"),
    (joint(target=INF, drive="position"), "Joint.target", "must be finite, got inf"),
    ([cressim.Joint("spherical", body_b=1, target_rotation=(0, 0, 0, 0))], "Joint.target_rotation",
     "non-zero quaternion"),
    # SoftBody
    ([cressim.SoftBody(BOX, mass=-1, distance_compliance=1e-4)], "SoftBody.mass", "must be positive, got -1"),
    ([cressim.SoftBody(BOX, youngs_modulus=-5e3)], "SoftBody.youngs_modulus", "must be positive, got -5000"),
    ([cressim.SoftBody(BOX, youngs_modulus=NAN)], "SoftBody.youngs_modulus", "must be positive, got nan"),
    ([cressim.SoftBody(BOX, poisson_ratio=0.5)], "SoftBody.poisson_ratio", "must be in [0, 0.5), got 0.5"),
    ([cressim.SoftBody(BOX, density=NAN)], "SoftBody.density", "must be positive, got nan"),
    ([cressim.SoftBody(BOX, distance_compliance=NAN)], "SoftBody.distance_compliance", "got nan"),
    ([cressim.SoftBody(BOX, volume_compliance=-1e-4)], "SoftBody.volume_compliance", "must be >= 0"),
    ([cressim.SoftBody(BOX, damping=-1)], "SoftBody.damping", "must be >= 0, got -1"),
    ([cressim.SoftBody(BOX, radius=0)], "SoftBody.radius", "must be positive, got 0"),
    ([cressim.SoftBody(BOX, friction=-0.1)], "SoftBody.friction", "must be >= 0, got -0.1"),
    ([cressim.SoftBody(np.array([[0, 0, 0], [NAN, 0, 0]], np.float32))], "SoftBody.positions[1]", "must be finite"),
    # Fluid
    ([cressim.Fluid(POINTS, viscosity=-1)], "Fluid.viscosity", "must be >= 0, got -1"),
    ([cressim.Fluid(POINTS, radius=0)], "Fluid.radius", "must be positive, got 0"),
    ([cressim.Fluid(POINTS, rest_density=NAN)], "Fluid.rest_density", "got nan"),
    ([cressim.Fluid(POINTS, cohesion=-1)], "Fluid.cohesion", "must be >= 0"),
    ([cressim.Fluid(POINTS, surface_tension=-1)], "Fluid.surface_tension", "must be >= 0"),
    ([cressim.Fluid(POINTS, vorticity=NAN)], "Fluid.vorticity", "got nan"),
    ([cressim.Fluid(POINTS, friction=-1)], "Fluid.friction", "must be >= 0"),
    ([cressim.Fluid(POINTS, damping=-1)], "Fluid.damping", "must be >= 0"),
    ([cressim.Fluid(POINTS, emit_velocity=(0, 0, NAN))], "Fluid.emit_velocity[2]", "must be finite"),
    ([cressim.Fluid(POINTS, emit_origin=(INF, 0, 0))], "Fluid.emit_origin[0]", "must be finite"),
    # Strand
    ([cressim.Strand(POINTS, stretch_compliance=-1)], "Strand.stretch_compliance", "must be >= 0, got -1"),
    ([cressim.Strand(POINTS, bend_compliance=NAN)], "Strand.bend_compliance", "got nan"),
    ([cressim.Strand(POINTS, twist_compliance=-1)], "Strand.twist_compliance", "must be >= 0"),
    ([cressim.Strand(POINTS, mass=0)], "Strand.mass", "must be positive, got 0"),
    ([cressim.Strand(POINTS, radius=INF)], "Strand.radius", "must be positive, got inf"),
    ([cressim.Strand(POINTS, initial_twist=NAN)], "Strand.initial_twist", "must be finite"),
    ([cressim.Strand(POINTS, damping=-1)], "Strand.damping", "must be >= 0"),
    ([cressim.Strand(POINTS, friction=-1)], "Strand.friction", "must be >= 0"),
    # rendering and sensing
    ([cressim.Renderable(0, color=(1, 0, 0, 2))], "Renderable.color[3]", "must be in [0, 1], got 2"),
    ([cressim.Renderable(0, metallic=2)], "Renderable.metallic", "must be in [0, 1], got 2"),
    ([cressim.Renderable(0, roughness=NAN)], "Renderable.roughness", "got nan"),
    ([cressim.Renderable(0, normal_scale=INF)], "Renderable.normal_scale", "must be finite"),
    ([cressim.Strand(POINTS), cressim.Material(color=(-1, 0, 0, 1))], "Material.color[0]", "must be >= 0, got -1"),
    ([cressim.Camera(fov_y=0)], "Camera.fov_y", "must be in (0, 180) degrees"),
    ([cressim.Camera(near=0)], "Camera.near", "must be positive, got 0"),
    ([cressim.Camera(near=1, far=0.5)], "Camera.far", "must be beyond near"),
    ([cressim.Camera(fx=-100)], "Camera.fx", "must be >= 0, got -100"),
    ([cressim.Camera(cx=NAN)], "Camera.cx", "must be finite"),
    ([cressim.Light(intensity=-1)], "Light.intensity", "must be >= 0, got -1"),
    ([cressim.Light(color=(1, NAN, 1))], "Light.color[1]", "got nan"),
    ([cressim.Light(ambient=-0.1)], "Light.ambient", "must be >= 0"),
    ([cressim.Light(kind="point", range=NAN)], "Light.range", "got nan"),
    ([cressim.Light(shadows=True, shadow_extent=0)], "Light.shadow_extent", "must be positive, got 0"),
    ([cressim.EnvironmentLight(intensity=NAN)], "EnvironmentLight.intensity", "got nan"),
    ([cressim.EnvironmentLight(sky=(-1, 0, 0))], "EnvironmentLight.sky[0]", "must be >= 0, got -1"),
    (probe(gain=NAN), "UltrasoundProbe.gain", "must be finite"),
    (probe(dynamic_range=0), "UltrasoundProbe.dynamic_range", "must be positive, got 0"),
    (probe(focal_depth=-1), "UltrasoundProbe.focal_depth", "must be >= 0"),
    (probe(kind="linear", line_spacing=0), "UltrasoundProbe.line_spacing", "must be positive"),
    (tissue(amplitude_mean=NAN), "UltrasoundTissue.amplitude_mean", "must be finite"),
    (tissue(inclusions=[cressim.UltrasoundInclusion((0, 0, 0), 0)]), "UltrasoundTissue.inclusions[0].radius",
     "must be positive, got 0"),
    (tissue(center=(0, INF, 0)), "UltrasoundTissue.center[1]", "must be finite"),
    (tissue(attenuation=-1), "UltrasoundTissue.attenuation", "must be >= 0"),
]


def scene(components):
    """env 0: an entity; env 1: a rigid body (entity 1) and the entity 'bad' (2) with `components`."""
    world = cressim.World(cressim.SceneLayout(2))
    world.add_mesh(cressim.Mesh.box((0.1, 0.1, 0.1)))
    world.create_entity(env=0, name="pad")
    world.create_entity(env=1, name="body").add(cressim.RigidBody(mass=1)).add(cressim.Collider(SPHERE))
    bad = world.create_entity(env=1, name="bad")
    for c in components:
        bad.add(c)
    return world


@pytest.mark.parametrize("components, field, message", BAD, ids=[f"{b[1]}-{i}" for i, b in enumerate(BAD)])
def test_bad_value_names_entity_env_and_field(make_engine, components, field, message):
    engine = make_engine(scene(components))
    with pytest.raises(cressim.AuthoringError) as e:
        engine.prepare()
    assert (e.value.entity, e.value.env, e.value.field, e.value.source) == (2, 1, field, "")
    assert str(e.value).startswith(f"entity 2 'bad' in env 1: {field} "), str(e.value)
    assert message in str(e.value), str(e.value)
    assert isinstance(e.value, ValueError)


def test_every_component_at_its_defaults_prepares(make_engine):
    components = [cressim.Transform(), cressim.RigidBody(), cressim.Collider(SPHERE), cressim.Renderable(0),
                  cressim.Camera(), cressim.Light(), cressim.EnvironmentLight(), cressim.UltrasoundProbe(),
                  cressim.UltrasoundTissue(count=10)]
    engine = make_engine(scene(components))
    world = engine.world
    for particles in (cressim.SoftBody(BOX), cressim.Fluid(POINTS), cressim.Strand(POINTS)):
        world.create_entity(env=0).add(particles).add(cressim.Material())
    world.create_entity(env=1, name="hinge").add(cressim.Joint("hinge", body_b=2))
    engine.prepare()


def test_a_non_finite_mesh_vertex_is_refused(make_engine):
    world = cressim.World(cressim.SceneLayout(1))
    positions = np.array([[0, 0, 0], [1, 0, 0], [0, NAN, 0]], np.float32)
    world.add_mesh(cressim.Mesh(positions, np.array([[0, 1, 2]]), np.tile([0, 0, 1], (3, 1)).astype(np.float32)))
    with pytest.raises(ValueError, match=r"mesh 0: positions must be finite, got nan"):
        make_engine(world).prepare()


def test_builder_errors_are_authoring_errors_too(make_engine):
    world = cressim.World(cressim.SceneLayout(1))
    world.create_entity(env=0, name="liver").add(cressim.SoftBody(POINTS, tets=np.array([[0, 1, 2, 7]])))
    with pytest.raises(cressim.AuthoringError) as e:
        make_engine(world).prepare()
    assert (e.value.entity, e.value.env, e.value.field) == (0, 0, "SoftBody.tets")


def test_sources_lead_the_message(make_engine):
    world = scene([cressim.RigidBody(), cressim.Collider(SPHERE, restitution=5)])
    world.set_source(2, "", "s.yaml:7")
    world.set_source(2, "Collider", "s.yaml:9")
    world.set_source(2, "Collider.restitution", "s.yaml:11")
    world.set_source(2, "Collider.shapes", "s.yaml:10")
    assert world.source_of(2, "Collider.shapes[0].size") == "s.yaml:10"  # the nearest parent known
    assert world.source_of(2, "RigidBody.mass") == "s.yaml:7"
    assert world.source_of(1, "Collider") == ""
    with pytest.raises(cressim.AuthoringError) as e:
        make_engine(world).prepare()
    assert e.value.source == "s.yaml:11"
    assert str(e.value).startswith("s.yaml:11: entity 2 'bad' in env 1: Collider.restitution must be in [0, 1]")


# ---- a component replaced after upload_world() -------------------------------------------------

def ball_world():
    world = cressim.World(cressim.SceneLayout(1))
    ball = world.create_entity(env=0, name="ball")
    ball.add(cressim.Transform(position=(0, 0, 1))).add(cressim.RigidBody(mass=1)).add(cressim.Collider(SPHERE))
    return world, ball


def test_a_replaced_collider_asks_for_prepare_then_applies(make_engine):
    world, ball = ball_world()
    engine = make_engine(world)
    engine.prepare()
    engine.upload_world()
    ball.add(cressim.Collider(cressim.Shape.sphere(0.3), restitution=0.5))
    with pytest.raises(cressim.TopologyError, match=r"entity 0 'ball' in env 0 replaced its Collider.*prepare\(\)"):
        engine.step_physics()
    engine.prepare()
    engine.upload_world()
    engine.step_physics()
    engine.end_frame()
    collider = engine.buffer("rigid.colliders").read().view(np.float32)[0]  # position, rotation, size, material
    assert collider[8] == pytest.approx(0.3) and collider[14] == pytest.approx(0.5)


def test_a_replaced_component_is_checked_at_prepare(make_engine):
    world, ball = ball_world()
    engine = make_engine(world)
    engine.prepare()
    engine.upload_world()
    ball.add(cressim.RigidBody(mass=-2))
    with pytest.raises(cressim.AuthoringError, match="'ball' in env 0: RigidBody.mass must be >= 0"):
        engine.prepare()


def test_a_replaced_transform_applies_as_a_value(make_engine):
    world, ball = ball_world()
    engine = make_engine(world)
    engine.prepare()
    engine.upload_world()
    version = world.topology_version
    ball.add(cressim.Transform(position=(2, 3, 4)))
    assert world.topology_version == version
    engine.end_frame()
    assert list(engine.buffer("transform.positions").read()[0, :3]) == [2, 3, 4]
    assert list(engine.buffer("rigid.positions").read()[0, :3]) == [2, 3, 4]


def test_a_transform_set_while_running_is_checked_as_it_is_set(make_engine):
    world, ball = ball_world()
    engine = make_engine(world)
    engine.prepare()
    engine.upload_world()
    with pytest.raises(cressim.AuthoringError, match=r"'ball' in env 0: Transform.position\[2\] must be finite, got nan"):
        ball.transform = cressim.Transform(position=(0, 0, NAN))
    with pytest.raises(cressim.AuthoringError, match="Transform.rotation must be a non-zero quaternion"):
        ball.add(cressim.Transform(rotation=(0, 0, 0, 0)))
    assert list(ball.transform.position) == [0, 0, 1]  # unchanged
