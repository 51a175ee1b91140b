"""UltrasoundScan: a linear probe is moved over deforming tissue to centre a dark target in its
ultrasound image (the paper's ultrasound task, ../shared/TASKS.md), z up.

Workload, as published: a 0.45 cube of tissue with 1e6 scatterers per unit volume (about
84,000 per env after the target's) and an anechoic sphere of radius 0.12 at its centre; a linear probe of 96
scanlines 0.006 apart, 0.7 long, imaged into 130 x 160 (width x height); action (2): lateral
and depth moves of 0.01 per unit, offsets clamped to +-0.22; observation: the image, 4 frames
stacked; reward: progress toward centring the target - 0.01 per step, +1 on success
(normalised distance <= 0.06, as TargetCenter); truncated at 160 steps.

Not published, chosen here: the probe looks straight down with its face on the tissue's top
and starts at a lateral offset drawn per env at build time (uniform +-0.15, seeded), to which
each episode of that env returns; the depth move is along the beam. The target's distance is
measured in the image, normalised by the image's half width and half depth. Pulse: 3.5 MHz,
60 % bandwidth, 40 MHz sampling decimated by 8, lateral and elevational beam widths 0.015 and
0.04, 50 dB shown, with one scene unit standing for 0.1 m (metres_per_unit = 0.1): the paper's
scene is ten times life size for the probe, so the image is 7 cm deep; soft-tissue attenuation
(0.5 dB/cm/MHz) with a time-gain compensation that matches it (3.5 dB/cm).

The tissue is a soft body (6 x 6 x 6 cubes of 6 tets: 343 particles and 1,296 tets per env, its
bottom face clamped, gravity on) whose scatterers ride in its tets, and the probe has a box
collider at its face: pressing the probe in (the depth action) indents the tissue and the image
deforms with it. The target is the tissue's centre particle, so it moves with the tissue.
Per env: about 84,000 scatterers and 343 particles (`scatterers`, `particles_per_env`; both in
the bench JSON).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

import cressim

from .vector_env import box, VectorEnv

CUBE = 0.225  # half extent
CELLS = 6     # tet-mesh cubes along each edge (even: a particle sits at the centre)
TARGET_RADIUS = 0.12
RADIUS = 0.01  # particle collision radius
LINES, SPACING, LENGTH, WIDTH, HEIGHT = 96, 0.006, 0.7, 130, 160
FRAMES = 4


class UltrasoundScan(VectorEnv):
    hlsl = Path(__file__).with_name("ultrasound_scan.hlsl")
    single_observation_space = box((FRAMES, HEIGHT, WIDTH), 0.0, 1.0)
    single_action_space = box((2,), -1.0, 1.0)
    max_episode_steps = 160
    step_size = 0.01
    limit = 0.22
    success = 0.06
    start_range = 0.15
    density = 1e6
    video_view = ((0.6, -1.2, 0.7), (0.0, 0.0, 0.0))

    def __init__(self, num_envs: int, **kwargs):
        super().__init__(num_envs, **kwargs)
        for observe in self.passes["observe"] + self.passes["observe_final"]:  # a thread per pixel
            observe.set_threads((num_envs * HEIGHT * WIDTH, 1, 1))

    @staticmethod
    def probe() -> cressim.UltrasoundProbe:
        return cressim.UltrasoundProbe(
            kind="linear", scanlines=LINES, line_spacing=SPACING, line_length=LENGTH, width=WIDTH, height=HEIGHT,
            center_frequency=3.5e6, fractional_bandwidth=0.6, sampling_frequency=40e6, radial_decimation=8,
            lateral_beam_width=0.015, elevational_beam_width=0.04, metres_per_unit=0.1, dynamic_range=50.0,
            gain=-20.0, time_gain_compensation=0.5 * 3.5 * 2)

    def build_world(self, num_envs: int) -> cressim.World:
        return self.scene(num_envs, self.env_offset)

    @classmethod
    def scene(cls, num_envs: int, env_offset: int = 0) -> cressim.World:
        """The task's world without its passes (benchmarks/bench_ultrasound.py images it alone);
        `env_offset` as in VectorEnv (the starts of envs env_offset on of one draw)."""
        world = cressim.World(cressim.SceneLayout(num_envs))
        starts = np.random.default_rng(12345).uniform(-cls.start_range, cls.start_range,
                                                      env_offset + num_envs)[env_offset:]
        cyst = cressim.UltrasoundInclusion((0, 0, 0), TARGET_RADIUS, amplitude_scale=0.0)
        mesh = cressim.TetMesh.box((CUBE, CUBE, CUBE), (CELLS, CELLS, CELLS))
        bottom = np.flatnonzero(np.isclose(mesh.positions[:, 2], -CUBE)).tolist()
        for env in range(num_envs):
            tissue = world.create_entity(env=env, name="tissue")
            tissue.add(cressim.Transform())
            tissue.add(cressim.SoftBody(mesh, fixed=bottom, mass=0.01, radius=RADIUS, distance_compliance=1e-3,
                                        volume_compliance=1e-4, damping=5.0))
            tissue.add(cressim.UltrasoundTissue(density=cls.density, inclusions=[cyst]))
            probe = world.create_entity(env=env, name="probe")
            # looks down, its face a particle radius above the tissue's top particles
            probe.add(cressim.Transform(position=(float(starts[env]), 0, CUBE + RADIUS), rotation=(1, 0, 0, 0)))
            probe.add(cressim.RigidBody(kinematic=True))
            # the probe's body behind its face (its -z), wider than the particle spacing across the
            # beam and deep enough that pressed particles cannot pass through it: pressing indents
            probe.add(cressim.Collider(cressim.Shape.box((0.3, 0.08, 0.1), position=(0, 0, -0.1)), group=0, mask=0))
            probe.add(cls.probe())
        return world

    def physics_settings(self) -> cressim.PhysicsSettings:
        return cressim.PhysicsSettings(dt=1 / 60, substeps=1, iterations=1, max_contacts_per_env=0)

    def sense(self):
        self.engine.step_simulation_sensors()

    def task_bindings(self) -> dict:
        e, n = self.engine, self.num_envs
        m, probes = e.mapping, e.ultrasound_probes
        assert (probes["env"] == np.arange(n)).all() and (probes["layer"] == np.arange(n)).all()
        rows = m["entity_row"]
        body_entity = e.buffer("rigid.body_entity").read()
        objects = e.buffer("particles.objects").read()  # x first particle, z env: one soft body an env
        task_rows = np.zeros((n, 4), np.uint32)
        task_rows[:, 0] = rows[probes["entity"]]
        task_rows[objects[:, 2], 1] = objects[:, 0] + self.centre_particle()
        task_rows[m["env_index"][rows[body_entity]], 2] = np.arange(len(body_entity))
        buffers = {"task_rows": e.create_shared_buffer("task_rows", (n, 4), "uint32"),
                   "probe_offset": e.create_shared_buffer("probe_offset", (n, 2), "float32"),
                   "prev_distance": e.create_shared_buffer("prev_distance", n, "float32")}
        buffers["task_rows"].write(task_rows)
        return {**buffers, "positions": "transform.positions", "rotations": "transform.rotations",
                "particles": "particles.positions",
                "initial_positions": "transform.initial_positions", "image": "ultrasound0.image",
                "body_targets": "control.body_target_positions"}

    def task_constants(self, reset_all: bool) -> dict:
        return {"envs": self.num_envs, "max_steps": self.max_episode_steps, "seed": self.seed,
                "step": self.step_size, "limit": self.limit, "half_width": 0.5 * LINES * SPACING,
                "line_length": LENGTH, "success": self.success, "pixels": HEIGHT * WIDTH, "frames": FRAMES,
                "reset_all": int(reset_all)}

    @staticmethod
    def centre_particle() -> int:
        """The tissue's particle at its centre (the target), in the object's own numbering."""
        mesh = cressim.TetMesh.box((CUBE, CUBE, CUBE), (CELLS, CELLS, CELLS))
        return int(np.argmin(np.linalg.norm(mesh.positions, axis=1)))

    @property
    def scatterers(self) -> int:
        return int(self.engine.ultrasound_probes["scatterers"])

    @property
    def particles_per_env(self) -> int:
        return int(self.engine.buffer("particles.positions").shape[0]) // self.num_envs
