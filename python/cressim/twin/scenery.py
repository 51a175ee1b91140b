"""What the twin's camera sees: the arm's URDF visuals, a table and a tissue block, a light, and
one camera per env, authored into the engine's world next to the arm's bodies; optionally an
ultrasound probe on the tissue with scatterers in the tissue under it.

World. With an engine scene file (the twin file's `world:`, scenes/*.yaml in the scene-file
format of cressim.scene_file), its entities replace the rigid table and block in every env:
soft tissue, blood, threads, tables, lights (its cameras are left out: the twin's camera is its
own). Its segmentation ids are shifted past the arm's, and `labels` names them by entity. A
world with particles is simulated: the twin steps the engine every tick (TwinArms), with the
attachment slots the jaws' grasp needs (`PARTICLE_SETTINGS`).

Visuals. Each arm body gets one Renderable (cressim.robots.ArmVisuals: its links' URDF visual
geometry merged into one mesh, shared by all envs). The scenery is visual only: it has no colliders, so it never changes the arm's motion.

Ultrasound (`UltrasoundSpec`, when the twin starts with the `ultrasound` sensor group): a
linear 7.5 MHz probe (laparoscopic-like, 64 lines over 19 mm, 2 cm deep) rests on the tissue
beside the tool looking down; the tissue block carries scatterers in a slab under the probe (as
thick as the elevational beam reaches) with an anechoic cyst, so the image shows speckle and a
dark disc. The density is below fully developed speckle (about 3 per resolution cell) to keep a
frame cheap on a CPU; docs/ultrasound.md says what the sensor models.

Segmentation ids are the same in every env: arm body k is k + 1 (in `labels` order), then the
tissue and the table; `labels` maps id -> name for the `segmentation/labels` topic.
"""
from __future__ import annotations

from dataclasses import dataclass
import numpy as np
import trimesh

import cressim
from cressim.config import Field, read_file
from cressim.robots.kinematics import rotation_xyzw
from cressim.scene_file import add_scene

TISSUE_HALF = (0.05, 0.04, 0.01)  # m: a block of tissue under the tool
TISSUE_COLOR = (0.78, 0.38, 0.36, 1.0)
TABLE_HALF = 0.4
TABLE_COLOR = (0.35, 0.42, 0.35, 1.0)
# particle solver of a simulated world, and attachment slots for the jaws' grasp
# (cressim.passes.Grasp: the particles within reach, nearest first). Without fluid: 2 elastic
# iterations with the contact passes once a substep, TissueRetract's on the same flap (the held
# force within 1.5 % of 4 iterations, the shape within 0.03 mm), which halves the tick's GPU time
# (benchmarks/profile_twin.py); blood keeps 4 density iterations with contacts in each.
PARTICLE_SETTINGS = dict(particle_iterations=4, max_particle_attachments_per_env=8)
SOLID_PARTICLE_SETTINGS = dict(PARTICLE_SETTINGS, particle_iterations=2, particle_contact_iterations=1)
PARTICLE_KEYS = ("soft_body", "fluid", "strand")


@dataclass(frozen=True)
class UltrasoundSpec:
    """The twin's probe: on the tissue's top face at `x` (m, world), looking down (its +z)."""
    x: float = 0.025
    scanlines: int = 64
    line_spacing: float = 0.0003  # m
    depth: float = 0.02  # m, imaged depth (the line length)
    width: int = 96  # output pixels
    height: int = 96
    center_frequency: float = 7.5e6  # Hz
    density: float = 2e10  # scatterers per m^3 (20 per mm^3)
    cyst_radius: float = 0.003  # m, anechoic, centred under the probe at half the tissue depth
    frame: str = "ultrasound_probe"

    def probe(self) -> cressim.UltrasoundProbe:
        return cressim.UltrasoundProbe(kind="linear", scanlines=self.scanlines, line_spacing=self.line_spacing,
                                       line_length=self.depth, width=self.width, height=self.height,
                                       center_frequency=self.center_frequency, lateral_beam_width=0.0005,
                                       elevational_beam_width=0.0015, radial_decimation=4,
                                       # TGC for the tissue's default 0.5 dB/cm/MHz two ways at 7.5 MHz
                                       time_gain_compensation=0.5 * 2 * self.center_frequency / 1e6)


@dataclass(frozen=True)
class CameraSpec:
    """One camera per env, posed in the env's world (z up) by position and a point it looks at."""
    width: int = 640
    height: int = 480
    fov_y: float = 60.0  # degrees
    position: tuple = (0.12, -0.12, 0.32)
    look_at: tuple = (0.0, 0.0, 0.19)
    near: float = 0.01
    far: float = 5.0
    table_z: float = 0.15  # height of the table top; the tissue block rests on it

    def intrinsics(self) -> tuple[float, float, float, float]:
        """fx, fy, cx, cy in the engine's convention (pixel i spans [i, i + 1))."""
        fy = 0.5 * self.height / np.tan(np.radians(self.fov_y) / 2)
        return fy, fy, self.width / 2, self.height / 2


def look_at_rotation(position, target, up=(0.0, 0.0, 1.0)) -> tuple:
    """xyzw of the optical frame (z forward, x right, y down) at `position` looking at `target`."""
    z = np.asarray(target, float) - np.asarray(position, float)
    z /= np.linalg.norm(z)
    x = np.cross(z, up)
    if np.linalg.norm(x) < 1e-6:  # looking straight up or down: any right will do
        x = np.cross(z, (0.0, 1.0, 0.0))
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return rotation_xyzw(np.stack([x, y, z], axis=1))


def engine_mesh(mesh: trimesh.Trimesh) -> cressim.Mesh:
    return cressim.Mesh(np.asarray(mesh.vertices, np.float32), np.asarray(mesh.faces, np.uint32),
                        np.asarray(mesh.vertex_normals, np.float32))


@dataclass(frozen=True)
class SceneryPlan:
    """What cressim.robots.ArmBodies builds next to the arm: it sizes the layout with
    `layout_limits`, adds `physics_settings` to the engine's and calls `build` once the arm's
    bodies and visuals are known."""
    camera: CameraSpec
    ultrasound: UltrasoundSpec | None = None
    world: str = ""  # an engine scene file; empty: the rigid table and block

    def _file(self) -> dict[str, Field]:
        """The world file's sections, peeked at (checked in full when the world loads: cressim.scene_file)."""
        root = read_file(self.world) if self.world else None
        return root.items() if root is not None and root.is_map() else {}

    def _entities(self) -> list[dict[str, Field]]:
        f = self._file().get("entities")
        return [e.items() for e in f.list() if e.is_map()] if f is not None and f.is_list() else []

    def layout_limits(self, num_bodies: int) -> dict:
        if not self.world:  # the arm's bodies, the table and the tissue
            return dict(max_renderables_per_env=num_bodies + 2, max_lights_per_env=1, max_cameras_per_env=1)
        entities = self._entities()
        lights = 1 + sum("light" in e for e in entities) + ("environment" in self._file())
        drawn = sum("renderable" in e or any(k in e for k in PARTICLE_KEYS) for e in entities)  # particles count
        return dict(max_renderables_per_env=num_bodies + drawn,
                    max_lights_per_env=lights, max_cameras_per_env=1)

    def simulated(self) -> bool:
        """Whether the world moves by itself (particles), so the engine steps every tick."""
        return any(k in e for e in self._entities() for k in PARTICLE_KEYS)

    def has_fluid(self) -> bool:
        return any("fluid" in e for e in self._entities())

    def has_heat(self) -> bool:
        """Whether a soft body of the world carries heat (`thermal`), so an instrument can burn it."""
        return any("soft_body" in e and e["soft_body"].is_map() and "thermal" in e["soft_body"].items()
                   for e in self._entities())

    def physics_settings(self) -> dict:
        if not self.simulated():
            return {}
        return dict(PARTICLE_SETTINGS if self.has_fluid() else SOLID_PARTICLE_SETTINGS)

    def build(self, world, visuals) -> "Scenery":
        return Scenery(world, visuals, self.camera, self.ultrasound, self.world)


class Scenery:
    """Authors visuals, scenery, light and camera into a world (call `add_env` for each env)."""

    def __init__(self, world, visuals, camera: CameraSpec, ultrasound: UltrasoundSpec | None = None,
                 scene_file: str = ""):
        self.camera, self.ultrasound, self.scene_file = camera, ultrasound, scene_file
        self.visuals = visuals
        self.body_meshes = [None if m is None else world.add_mesh(engine_mesh(m)) for m in visuals.meshes]
        self.tissue_mesh = world.add_mesh(cressim.Mesh.box(TISSUE_HALF))
        self.table_mesh = world.add_mesh(cressim.Mesh.plane(TABLE_HALF))
        n = len(visuals.names)
        self.tissue_id, self.table_id = n + 1, n + 2
        self.labels = {k + 1: name for k, name in enumerate(visuals.names)}
        self.world_probe = None
        if scene_file:  # every env's world at once, its ids after the arm's
            added = add_scene(world, scene_file, segmentation_offset=n)
            self.labels.update(added.labels)
            # the world's probe (ultrasound_phantom.yaml) is the twin's when it publishes ultrasound
            self.world_probe = added.probes[0] if added.probes else None
            if self.world_probe is None:
                self.ultrasound = None
        else:
            self.labels.update({self.tissue_id: "tissue", self.table_id: "table"})
        self.camera_rotation = look_at_rotation(camera.position, camera.look_at)

    def add_body_visual(self, entity, body_index: int):
        mesh = self.body_meshes[body_index]
        if mesh is not None:
            entity.add(cressim.Renderable(mesh, color=self.visuals.colors[body_index], metallic=0.3, roughness=0.4,
                                          segmentation_id=body_index + 1))

    def add_env(self, world, env: int):
        """Table, tissue, light and camera of one env; returns the camera's entity."""
        c = self.camera
        if not self.scene_file:
            self._add_block(world, env)
        light = world.create_entity(env=env, name="light")  # from above, slightly behind the camera
        light.add(cressim.Transform(rotation=look_at_rotation((0.2, -0.3, 1.0), (0.0, 0.0, 0.0))))
        light.add(cressim.Light(intensity=1.0, ambient=0.3))
        camera = world.create_entity(env=env, name="camera")
        camera.add(cressim.Transform(position=tuple(float(v) for v in c.position), rotation=self.camera_rotation))
        fx, fy, cx, cy = c.intrinsics()
        camera.add(cressim.Camera(width=c.width, height=c.height, fx=fx, fy=fy, cx=cx, cy=cy, near=c.near, far=c.far))
        return camera

    def _add_block(self, world, env: int):
        """The rigid table and tissue block of a twin without a world file."""
        c = self.camera
        table = world.create_entity(env=env, name="table")
        table.add(cressim.Transform(position=(0.0, 0.0, c.table_z)))
        table.add(cressim.Renderable(self.table_mesh, color=TABLE_COLOR, segmentation_id=self.table_id))
        tissue = world.create_entity(env=env, name="tissue")
        tissue.add(cressim.Transform(position=(0.0, 0.0, c.table_z + TISSUE_HALF[2])))
        tissue.add(cressim.Renderable(self.tissue_mesh, color=TISSUE_COLOR, roughness=0.3,
                                      segmentation_id=self.tissue_id))
        if self.ultrasound is not None:
            self._add_ultrasound(world, env, tissue)

    def probe_pose(self) -> tuple:
        """(position, xyzw) of the probe in the env's world: the world file's, or on the rigid
        tissue's top face, +z down."""
        if self.world_probe is not None:
            return self.world_probe
        top = self.camera.table_z + 2 * TISSUE_HALF[2]
        return (self.ultrasound.x, 0.0, top), (1.0, 0.0, 0.0, 0.0)

    def _add_ultrasound(self, world, env: int, tissue):
        u = self.ultrasound
        beam = 0.002  # m: half the slab's thickness, past 3 sigma of the 1.5 mm elevational beam
        half_x = u.scanlines * u.line_spacing / 2 + 0.002
        tissue.add(cressim.UltrasoundTissue(
            region="box", center=(u.x, 0.0, 0.0), size=(half_x, beam, TISSUE_HALF[2]), density=u.density,
            inclusions=[cressim.UltrasoundInclusion((u.x, 0.0, 0.0), u.cyst_radius)]))
        probe = world.create_entity(env=env, name="ultrasound_probe")
        position, rotation = self.probe_pose()
        probe.add(cressim.Transform(position=position, rotation=rotation))
        probe.add(u.probe())


__all__ = ["SceneryPlan", "CameraSpec", "Scenery", "UltrasoundSpec", "engine_mesh", "look_at_rotation"]
