"""What the particle tasks (SoftBodyPush, FluidPour) share: one pusher/container body per env,
the paper's 60 Hz frame with the task's substeps and particle iterations, no attachment slots
(no attachment pass), and the buffers their task passes read."""
from __future__ import annotations

import numpy as np

import cressim

from .vector_env import VectorEnv


class ParticleTask(VectorEnv):
    substeps = 4
    particle_iterations = 4
    contact_iterations = 0  # of the particle iterations, those that also solve contacts (0: all)

    def physics_settings(self) -> cressim.PhysicsSettings:
        return cressim.PhysicsSettings(dt=1 / 60, substeps=self.substeps, particle_iterations=self.particle_iterations,
                                       particle_contact_iterations=self.contact_iterations,
                                       max_particle_attachments_per_env=0)

    def task_bindings(self) -> dict:
        # one rigid body per env (the tool), in env order
        assert (self.engine.buffer("rigid.body_env").read() == np.arange(self.num_envs)).all(), "unexpected body layout"
        return {"particle_positions": "particles.positions", "particle_env_ranges": "particles.env_ranges",
                "body_positions": "rigid.positions", "target_positions": "control.body_target_positions"}
