"""Training beside the twin: one process, one engine, one timer (docs/twin.md).

The twin node runs in this process with num_envs = N and the dynamic arm. ROS drives env 0:
a dVRK-style client (cressim_ros.dvrk_client, on a thread of its own, as any external client
would be) enables, homes and moves /env0/PSM1 back and forth over DDS. Envs 1..N-1 belong to a
batched learner that runs inside the twin's tick as a step hook: each tick it reads the
engine's joint coordinates of its envs (one gather from the `joint.positions` tensor) and writes
their setpoints (one batched write; the twin turns them into drive targets with gravity
feed-forward), and every episode it resets its envs through the engine (`node.arms.reset_envs`).

The learner is a toy cross-entropy search, only here to show the plumbing: each training env
runs q_cmd = q + K (q_goal - q) on yaw, pitch and insertion from the same start toward the same
goal, with its own candidate gains K; the cost penalises distance to the goal and command steps
(so the best K is not simply 1); after each episode the gain distribution moves to the best
candidates.

    source ros_ws/env.sh
    python ros_ws/src/cressim_ros/examples/train_beside_twin.py --envs 7 --seconds 6

Prints one line per episode and a summary (the learner's cost, what the ROS client did).
"""
from __future__ import annotations

import argparse
import os
import sys
import threading
from pathlib import Path

import numpy as np
import rclpy
import torch
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # cressim_ros from the source tree

from cressim_ros.dvrk_client import Arm, Ral  # noqa: E402
from cressim_ros.twin_node import TwinNode  # noqa: E402
from cressim.twin import TwinArms  # noqa: E402

HOME = torch.tensor([0.0, 0.0, 0.12, 0.0, 0.0, 0.0], dtype=torch.float64)
GOAL = torch.tensor([0.4, -0.3, 0.16], dtype=torch.float64)  # yaw, pitch (rad), insertion (m)
STEP_COST = 0.3  # weight of the command steps in the cost


class CrossEntropyReach:
    """The step hook: a batched learner on envs `envs` of the twin's engine."""

    def __init__(self, arms: TwinArms, envs, episode_ticks: int, seed: int = 0):
        self.arms, self.episode_ticks = arms, episode_ticks
        self.envs = torch.as_tensor(envs, device=arms.device)
        self.gen = torch.Generator(device="cpu").manual_seed(seed)
        bodies = arms.bodies
        # the engine's joint coordinates (zero-copy view) and the rows of our envs' yaw, pitch, insertion
        self.positions = torch.from_dlpack(bodies.engine.buffer("joint.positions"))
        self.rows = bodies.joint_rows[self.envs, :3]
        self.mean = torch.full((3,), 0.2, dtype=torch.float64)
        self.std = torch.full((3,), 0.3, dtype=torch.float64)
        self.tick, self.episode, self.history = 0, 0, []

    def _start_episode(self):
        M = len(self.envs)
        self.K = (self.mean + self.std * torch.randn(M, 3, generator=self.gen, dtype=torch.float64)).clamp(0.01, 1.0)
        self.goal = GOAL.repeat(M, 1)
        self.cost = torch.zeros(M, dtype=torch.float64)
        self.arms.reset_envs(self.envs, HOME.repeat(M, 1))  # takes effect at this tick's engine step

    def __call__(self, arms: TwinArms):
        if self.tick == 0:
            self._start_episode()
        else:
            q = self.positions[self.rows].to(torch.float64).cpu()  # (M, 3): observation, one gather
            command = q + self.K * (self.goal - q)  # the policy, batched
            self.cost += ((self.goal - q) ** 2).sum(-1) + STEP_COST * ((command - q) ** 2).sum(-1)
            setpoint = arms.setpoint[self.envs].clone()
            setpoint[:, :3] = command.to(setpoint)
            arms.setpoint[self.envs] = setpoint  # the action, one batched write
        self.tick += 1
        if self.tick == self.episode_ticks:  # update: the best quarter of the candidates
            elite = self.K[torch.argsort(self.cost)[: max(2, len(self.envs) // 4)]]
            self.mean, self.std = elite.mean(0), elite.std(0).clamp_min(0.02)
            self.history.append(float(self.cost.mean()))
            self.episode += 1
            self.tick = 0
            print(f"episode {self.episode:3d}: mean cost {self.history[-1]:8.4f}, gains K = "
                  f"{np.round(self.mean.numpy(), 3).tolist()}", flush=True)


def ros_client(domain: int, stop: threading.Event, report: dict):
    """Drives /env0/PSM1 over DDS as an external dVRK client would."""
    ral = Ral("train_beside_twin_client", domain)
    try:
        arm = Arm(ral, "/env0/PSM1")
        ral.check_connections(timeout=20)
        report["enabled"] = arm.enable()
        report["homed"] = arm.home()
        goals = [np.array([0.3, -0.2, 0.15, 0.5, 0.2, 0.0]), np.array([-0.3, 0.2, 0.1, -0.5, -0.2, 0.0])]
        while not stop.is_set():
            goal = goals[report["moves"] % 2]
            if not arm.move_jp(goal).wait(timeout=120):  # a safety limit: a loaded machine ticks slowly
                break
            report["moves"] += 1
            report["error"] = float(np.abs(arm.measured_jp() - goal).max())
        report["rate"] = arm.measured_js_rate(1.0)
    finally:
        ral.shutdown()


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--envs", type=int, default=7, help="envs in the engine: 1 for ROS + the learner's")
    parser.add_argument("--seconds", type=float, default=6.0, help="run time, simulated seconds")
    parser.add_argument("--episode-ticks", type=int, default=40, help="learner episode length (ticks of 10 ms)")
    args = parser.parse_args(argv)
    if args.envs < 3:
        parser.error("--envs must be at least 3 (env 0 for ROS, two or more for the learner)")
    domain = int(os.environ.get("ROS_DOMAIN_ID", "0"))

    torch.set_num_threads(1)
    rclpy.init(domain_id=domain)
    node = TwinNode(parameter_overrides=[Parameter("num_envs", value=args.envs),
                                         Parameter("dynamics", value="dynamic"),
                                         Parameter("sensors", value=["joints", "cartesian"])])
    learner = CrossEntropyReach(node.arms, range(1, args.envs), args.episode_ticks)
    node.arms.step_hooks.append(learner)
    executor = SingleThreadedExecutor()
    executor.add_node(node)

    stop, report = threading.Event(), {"moves": 0}
    client = threading.Thread(target=ros_client, args=(domain, stop, report), daemon=True)
    client.start()
    try:
        # simulated time, so a slow machine runs the same experiment, only longer
        while node.arms.sim_ns < args.seconds * 1e9 or (report["moves"] == 0 and client.is_alive()):
            executor.spin_once(timeout_sec=0.05)
        stop.set()
        while client.is_alive():  # let the running move finish
            executor.spin_once(timeout_sec=0.05)
    finally:
        ticks = np.array(node._tick_times) * 1e3
        node.close()
        node.destroy_node()
        rclpy.try_shutdown()
    h = learner.history
    print(f"learner: {len(h)} episodes of {len(learner.envs)} envs, mean cost "
          f"{h[0] if h else float('nan'):.4f} -> {h[-1] if h else float('nan'):.4f}")
    print(f"ROS env 0: enabled {report.get('enabled')}, homed {report.get('homed')}, "
          f"{report['moves']} move_jp done, last error {report.get('error', float('nan')):.2e}, "
          f"measured_js at {report.get('rate', float('nan')):.0f} Hz")
    print(f"tick: mean {ticks.mean():.2f} ms, max {ticks.max():.2f} ms over {len(ticks)} ticks")
    return 0 if report["moves"] > 0 and len(h) > 1 else 1


if __name__ == "__main__":
    sys.exit(main())
