"""The planar elastica, an independent reference for rods: a cantilever clamped at s = 0 along +x,
bent in the x-z plane by a uniform moment M (a tendon of tension T at offset r gives T r all
along the rod: Rucker & Webster 2011, IEEE T-RO 27(6), for a tendon routed parallel to the
backbone) and a dead load P (N, along -z) at its tip:
    EI theta'(s) = M + P (x(L) - x(s)),  x' = cos theta,  z' = -sin theta,
theta the angle below +x, solved as a boundary value problem (scipy's solve_bvp); the classic
large-deflection cantilever (Bisshopp & Drucker 1945) is M = 0. For small loads the tip drops
P L^3 / 3 EI (Euler-Bernoulli). The reference of tests/physics/test_tendons.py and `cressim demo
cable` (independent of the engine; checked against Bisshopp & Drucker's table there)."""
import numpy as np
from scipy.integrate import solve_bvp


def cantilever_tip(length: float, EI: float, moment: float = 0.0, load: float = 0.0) -> np.ndarray:
    """(x, z) of the tip relative to the clamp (m); z is negative for a drop."""
    def rhs(s, y, p):
        theta, x, _ = y
        return np.vstack([(moment + load * (p[0] - x)) / EI, np.cos(theta), -np.sin(theta)])

    def bc(ya, yb, p):
        return np.array([ya[0], ya[1], ya[2], yb[1] - p[0]])

    s = np.linspace(0, length, 400)
    guess = np.vstack([0 * s, s, 0 * s])
    sol = solve_bvp(rhs, bc, s, guess, p=[length], tol=1e-9, max_nodes=100000)
    if not sol.success:
        raise RuntimeError(f"elastica did not converge: {sol.message}")
    return sol.y[1:, -1].copy()
