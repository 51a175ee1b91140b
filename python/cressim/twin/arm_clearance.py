"""Where the cart's arms meet: the instruments and the endoscope as capsules, checked pairwise.

The engine resolves a contact only where one body is dynamic, so the cart's kinematic arms pass
through each other; the real ones would clash. Each tick the cart checks the parts that share the
workspace, the PSMs' instruments (shaft and wrist, from the tool base to the jaw pivot) and the
ECM's scope, as capsules along their DH frames (segment-to-segment distance below the sum of the
radii), and reports a pair on both arms' `warning` when they start to touch and on `status` when
they part. A few arms: O(arms^2) segment distances, a few microseconds each.
"""
from __future__ import annotations

import numpy as np

INSTRUMENT_RADIUS = 0.0042  # m: the 8.4 mm instrument shaft (robots/dvrk_psm)
SCOPE_RADIUS = 0.006  # m: the 12 mm endoscope (robots/dvrk_ecm)


def segment_distance(p0, p1, q0, q1) -> float:
    """The shortest distance between segments p0-p1 and q0-q1 (3-vectors)."""
    d1, d2, r = p1 - p0, q1 - q0, p0 - q0
    a, e, f = d1 @ d1, d2 @ d2, d2 @ r
    if a < 1e-18 and e < 1e-18:
        return float(np.linalg.norm(r))
    if a < 1e-18:
        s, t = 0.0, np.clip(f / e, 0.0, 1.0)
    else:
        c = d1 @ r
        if e < 1e-18:
            s, t = np.clip(-c / a, 0.0, 1.0), 0.0
        else:
            b = d1 @ d2
            denom = a * e - b * b
            s = np.clip((b * f - c * e) / denom, 0.0, 1.0) if denom > 1e-18 else 0.0
            t = (b * s + f) / e
            if t < 0.0:
                s, t = np.clip(-c / a, 0.0, 1.0), 0.0
            elif t > 1.0:
                s, t = np.clip((b - c) / a, 0.0, 1.0), 1.0
    return float(np.linalg.norm((p0 + d1 * s) - (q0 + d2 * t)))


class ArmClearance:
    """Remembers which pairs touch; `update(capsules)` returns (onsets, partings) as name pairs."""

    def __init__(self):
        self.touching = set()

    def update(self, capsules: dict) -> tuple[list, list]:
        """capsules: name -> (p0, p1, radius) in one frame (the world)."""
        names = sorted(capsules)
        now = set()
        for i, a in enumerate(names):
            for b in names[i + 1:]:
                (p0, p1, ra), (q0, q1, rb) = capsules[a], capsules[b]
                if segment_distance(p0, p1, q0, q1) < ra + rb:
                    now.add((a, b))
        onsets, partings = sorted(now - self.touching), sorted(self.touching - now)
        self.touching = now
        return onsets, partings


__all__ = ["INSTRUMENT_RADIUS", "SCOPE_RADIUS", "ArmClearance", "segment_distance"]
