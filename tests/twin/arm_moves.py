"""Moving the twin's arms in tests without ROS: ticks, settling, and placing every env's jaws over a
point by IK."""
import numpy as np
import torch

from cressim.twin import JointCommand

EDGE = np.array([0.0, -0.0175, 0.1545])  # world: the retraction flap's free edge, mid-thickness
JAW_MIDDLE = 0.006  # m from the tool tip (the jaws' pivot) along the jaws


def run_ticks(arms, ticks):
    for _ in range(ticks):
        arms.tick()


def settle(arms):
    run_ticks(arms, 5)
    while any(s.is_busy for s in arms.states):
        run_ticks(arms, 5)


def jaws_at(arms, height, jaws=None, point=EDGE):
    """Every env's tool tip over `point` (world) with the jaws' middle `height` (one for all envs or
    one per env) above it (IK at the current setpoint, jaws down as at home); `jaws` (one per env)
    commands the jaw angles."""
    heights = np.broadcast_to(height, arms.num_envs)
    for env in range(arms.num_envs):
        T = arms.kin.forward(arms.setpoint[env:env + 1])[0].clone()
        T[:3, 3] = torch.as_tensor(point + np.array([0, 0, heights[env] + JAW_MIDDLE])) - arms.bodies.base[:3, 3]
        q, ok = arms.kin.inverse(T[None], arms.setpoint[env:env + 1])
        assert bool(ok[0])
        assert not [e for e in arms.move_jp(env, JointCommand(position=q[0].tolist())) if e.topic == "error"]
        if jaws is not None:
            arms.jaw_move_jp(env, JointCommand(position=[jaws[env]]))
    settle(arms)
