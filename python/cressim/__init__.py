"""CRESSim: a batched GPU simulation engine for surgical robotics and robot learning.

The frame pipeline (authoring, then stepping)::

    layout = cressim.SceneLayout(num_envs=64)
    world = cressim.World(layout)
    world.create_entity(env=0).add(cressim.Transform(position=(0, 0, 1)))
    engine = cressim.Engine(world)
    engine.prepare(); engine.upload_world()
    engine.step_physics(); engine.execute_compute_pass(p); engine.end_frame()
"""
from cressim._core import (
    AuthoringError,
    BindingError,
    Buffer,
    Camera,
    Collider,
    ComputePass,
    DeviceLostError,
    Engine,
    Entity,
    EnvironmentLight,
    Fluid,
    Joint,
    Light,
    Material,
    Mesh,
    Needle,
    PhysicsSettings,
    Renderable,
    RigidBody,
    Shape,
    SceneLayout,
    Texture,
    ShaderCompileError,
    SoftBody,
    Thermal,
    Strand,
    Tendons,
    TetMesh,
    TopologyError,
    Transform,
    UltrasoundInclusion,
    UltrasoundProbe,
    UltrasoundTissue,
    VulkanError,
    World,
    list_devices,
    read_buffers,
)
from cressim.compute import load_compute_pass
from cressim import sensors  # noqa: F401  (PNG export of sensor images)
from cressim import passes  # noqa: F401  (ready-made custom passes: grasp, suction)
from cressim.tendons import TendonDrive
from cressim.registration import register_envs

register_envs()  # the tasks as gymnasium's cressim/<Task>-v0

__all__ = [
    "AuthoringError",
    "BindingError",
    "Buffer",
    "Camera",
    "Collider",
    "ComputePass",
    "DeviceLostError",
    "Engine",
    "Entity",
    "EnvironmentLight",
    "Fluid",
    "Joint",
    "Light",
    "Material",
    "Mesh",
    "Needle",
    "PhysicsSettings",
    "Renderable",
    "RigidBody",
    "Shape",
    "SceneLayout",
    "Texture",
    "ShaderCompileError",
    "SoftBody",
    "Thermal",
    "Strand",
    "TendonDrive",
    "Tendons",
    "TetMesh",
    "TopologyError",
    "Transform",
    "UltrasoundInclusion",
    "UltrasoundProbe",
    "UltrasoundTissue",
    "VulkanError",
    "World",
    "list_devices",
    "read_buffers",
    "load_compute_pass",
]
