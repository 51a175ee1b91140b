"""Driving the tendons of cable-driven continuum robots (cressim.Tendons on a Strand) from the host.

Every tendon has a row of `control.tendon_commands` (float32 (tendons, 2): x the mode, y its
value), rows grouped by env; a task pass may write them itself. `particles.tendon_states` reads
back each tendon's length (m), tension (N) and target length. `TendonDrive` addresses them as
(envs, tendons per env) arrays::

    drive = TendonDrive(engine)
    drive.pull([0.002, 0.0, 0.0, 0.0])      # tendon 0 of every env 2 mm in, the others held
    drive.tension(np.full((envs, 4), 1.5))  # every tendon pulled with 1.5 N
    drive.lengths(), drive.tensions()
"""
from __future__ import annotations

import numpy as np

SLACK, DISPLACEMENT, TENSION = 0, 1, 2


class TendonDrive:
    def __init__(self, engine):
        if "particles.tendons" not in engine.internal_keys:
            raise ValueError("TendonDrive: the world has no tendons (add cressim.Tendons to a Strand)")
        self.engine = engine
        records = engine.buffer("particles.tendons").read()
        envs = engine.buffer("particles.env_ranges").shape[0]
        env_of = records[:, 5]
        per_env = np.bincount(env_of, minlength=envs)
        if (per_env != per_env[0]).any():
            raise ValueError(f"TendonDrive: every env needs the same tendons, got {per_env.tolist()} per env")
        self.envs, self.per_env = envs, int(per_env[0])
        self.rest_lengths = records[:, 2].view(np.float32).reshape(envs, self.per_env).copy()
        self.commands = engine.buffer("control.tendon_commands")

    def _values(self, values, what: str) -> np.ndarray:
        v = np.asarray(values, dtype=np.float64)
        try:
            v = np.broadcast_to(v, (self.envs, self.per_env))
        except ValueError:
            raise ValueError(f"TendonDrive.{what}: give one value, one per tendon ({self.per_env}) or "
                             f"(envs, tendons) = ({self.envs}, {self.per_env}); got shape {v.shape}") from None
        bad = np.argwhere(~np.isfinite(v))
        if len(bad):
            env, t = bad[0]
            raise ValueError(f"TendonDrive.{what}: env {env} tendon {t} must be finite, got {v[env, t]}")
        return v

    def _write(self, mode, values) -> None:
        rows = np.stack([np.broadcast_to(mode, values.shape), values], -1).reshape(-1, 2)
        self.commands.write(rows.astype(np.float32))

    def pull(self, displacement) -> None:
        """Each tendon pulled in by `displacement` (m; negative lets it out) from its rest length:
        held taut at that length (it pulls, never pushes)."""
        d = self._values(displacement, "pull")
        over = np.argwhere(np.abs(d) >= self.rest_lengths)
        if len(over):
            env, t = over[0]
            raise ValueError(f"TendonDrive.pull: env {env} tendon {t}: {d[env, t]} m is not shorter than its "
                             f"rest length {self.rest_lengths[env, t]:.6g} m")
        self._write(DISPLACEMENT, d)

    def tension(self, newtons) -> None:
        """Each tendon pulled with a tension (N, >= 0), its length free."""
        t = self._values(newtons, "tension")
        neg = np.argwhere(t < 0)
        if len(neg):
            env, k = neg[0]
            raise ValueError(f"TendonDrive.tension: env {env} tendon {k} must be >= 0 N (a tendon cannot push), "
                             f"got {t[env, k]}")
        self._write(TENSION, t)

    def slack(self) -> None:
        """Every tendon let go: no force."""
        self._write(SLACK, np.zeros((self.envs, self.per_env)))

    def _states(self) -> np.ndarray:
        return self.engine.buffer("particles.tendon_states").read().reshape(self.envs, self.per_env, 4)

    def lengths(self) -> np.ndarray:
        """(envs, tendons) route lengths (m) at the last step."""
        return self._states()[..., 0].copy()

    def tensions(self) -> np.ndarray:
        """(envs, tendons) tensions (N) at the last step: the commanded one in tension mode, the
        one holding the length in displacement mode, 0 slack."""
        return self._states()[..., 1].copy()
