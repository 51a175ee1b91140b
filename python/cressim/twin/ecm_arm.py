"""The patient cart's ECM in the dVRK's terms, without ROS: the ECM kind of the arm model.

    ecm = EcmArm(initial_jp, home_jp, publish_rate=100.0)
    events = ecm.state_command(0, "enable")   # the dVRK's state machine, one row (cressim.twin.arm_model)
    events = ecm.move_jp(0, JointCommand(position=[0.1, 0.2, 0.08, 0.0]))
    events = ecm.tick()                         # trajectories; measured follows setpoint (lag)

The commands, events and the tick are ArmModel's (the PSM's, written once); this file holds what
is the ECM's: its four joints and limits, its kinematics (cressim.robots.ecm) and the dVRK's way
with Cartesian goals. The ECM is kinematic: the cart poses its links and the stereo cameras on
its tip from `measured` (cressim.twin.cart). A Cartesian goal (move_cp, servo_cp, the tip in
measured_cp's frame) is re-aligned as the dVRK's ECM does: its four joints point the scope at
the goal's position (its z along the line from the RCM) and roll it to the goal's x as near as
that allows; only a position beyond the joint limits is refused.
"""
from __future__ import annotations

import numpy as np
import torch

from cressim.robots.ecm import (ECM_JOINT_NAMES, ECM_LOWER, ECM_UPPER, ECM_VELOCITY, ecm_forward_kinematics,
                                ecm_inverse_kinematics, ecm_jacobian)

from .arm_model import ArmModel

ACCELERATION_RATIO = 4.0  # acceleration limit = ratio x velocity limit, per second (as the PSM's default)
POSITION_TOLERANCE = 1e-5  # m: a re-aligned goal the joints reach closer than this is reached


class EcmKinematics:
    """The ECM's kinematics as ArmModel takes them (batched torch in, torch out)."""

    def __init__(self):
        self.lower_np, self.upper_np = ECM_LOWER.copy(), ECM_UPPER.copy()
        self.lower, self.upper = torch.as_tensor(self.lower_np), torch.as_tensor(self.upper_np)

    def forward(self, q: torch.Tensor) -> torch.Tensor:
        return ecm_forward_kinematics(q)

    def jacobian(self, q: torch.Tensor):
        return ecm_jacobian(q)

    def inverse(self, T: torch.Tensor, seed: torch.Tensor):
        """(M, 4, 4) goals -> (q (M, 4), reachable (M,)): each goal re-aligned to the scope's line
        (the closed form of cressim.robots.ecm), reachable where the joints put the tip at its position."""
        q, ok = [], []
        for goal in T.cpu().numpy():
            qi, _ = ecm_inverse_kinematics(goal)  # within the limits; its own flag also asks for the goal's z
            q.append(qi)
            ok.append(np.linalg.norm(ecm_forward_kinematics(qi)[:3, 3] - goal[:3, 3]) < POSITION_TOLERANCE)
        return torch.as_tensor(np.stack(q)), torch.as_tensor(ok)


class EcmArm(ArmModel):
    unreachable = "(ECM_base) is not reachable: the scope points at it only beyond its joint limits"

    def __init__(self, initial_jp, home_jp, *, measured_lag: float = 0.005, name: str = "ECM",
                 publish_rate: float = 100.0):
        initial, home = np.asarray(initial_jp, dtype=np.float64), np.asarray(home_jp, dtype=np.float64)
        for what, q in (("initial_jp", initial), ("home_jp", home)):
            if np.any(q < ECM_LOWER) or np.any(q > ECM_UPPER):
                raise ValueError(f"cart.{name}.{what} {q.tolist()} is outside the ECM's joint limits "
                                 f"{ECM_LOWER.tolist()} .. {ECM_UPPER.tolist()}")
        super().__init__(EcmKinematics(), ECM_JOINT_NAMES, num_envs=1, initial_q=initial, home_q=home,
                         v_limit=ECM_VELOCITY, a_limit=ECM_VELOCITY * ACCELERATION_RATIO,
                         period_ns=int(round(1e9 / publish_rate)), name=name, measured_lag=measured_lag)
        self.name = name

    def local_cp(self, which: str = "measured") -> np.ndarray:
        """(4, 4): the endoscope's tip (DH frame 4) in ECM_base (the RCM)."""
        return ecm_forward_kinematics(getattr(self, which)[0].numpy())

    def cp(self, which: str = "measured") -> np.ndarray:
        return self.base_frame_np[0] @ self.local_cp(which)


__all__ = ["EcmArm", "EcmKinematics"]
