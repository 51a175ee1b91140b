"""Sim to real: a policy trained in batch drives the twin's PSM as a dVRK client, over CRTK
topics only, so that the same client can face a real dVRK (docs/twin.md, "Sim to real").

1. Train in batch (TissueRetract in the twin's own scene, psm_retraction.yaml, with the CRTK
   observation: only what a client knows from the arm's Cartesian pose and its own commands;
   examples/policies/tissue_retract_crtk.pt was trained so on an H200, benchmarks/README.md):

       python -m cressim train TissueRetract --envs 1024 --iterations 140 --backend torch \\
           --task-option observation=crtk --task-option absorbing_success=true --out runs/sim_to_real

2. Drive PSM1 with it. The client is the dVRK's own Python package (`dvrk.psm` on `crtk.ral`,
   taken from $CRESSIM_DVRK_CLIENTS or ../shared/third_party): it enables and homes the arm,
   opens the jaws, then every 1/60 s of the arm's clock (setpoint_cp's stamps: the twin's
   simulated time, a real arm's wall time), once the arm has taken the last command, reads
   setpoint_cp, computes the observation (cressim.envs.tissue_retract_client), runs the policy
   and sends servo_jp and jaw/servo_jp.
   `--twin` starts the twin on psm_retraction.yaml first (leave it out for a running twin or a
   real dVRK and its console):

       source ros_ws/env.sh
       python ros_ws/src/cressim_ros/examples/sim_to_real.py --policy runs/sim_to_real/model_140.pt --twin

The target is one of the flap's free-edge particles at rest (`--target`, in the twin's world,
default the middle one): what a registered camera would give. The client stops on success (the
jaws closed and the tool tip 20 mm above where they closed: the task's success as the CRTK
observation sees it) or after the task's 180 steps, holds for `--hold` s and reports the force on
the tool (spatial/measured_cf) and the lift; exit status 0 on success. The batched task ends an
episode on the held particle's 20 mm rise, which a client cannot see; the policy here reaches the
client's criterion too (the particle rose more than the tip where the flap bulged under the jaws).
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[4]
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # cressim_ros from the source tree

MIDDLE_OF_FREE_EDGE = (0.0, -0.02, 0.1575)  # m: tissue_retraction.yaml's flap, top layer, world frame
MAX_STEPS = 180  # the task's episode
STEP = 1 / 60  # s of the arm's clock: the task's frame


def dvrk_clients() -> Path:
    value = os.environ.get("CRESSIM_DVRK_CLIENTS")
    return (REPO / value).resolve() if value else (REPO.parent / "shared" / "third_party").resolve()


def frame_matrix(frame) -> np.ndarray:
    """A PyKDL.Frame (what crtk returns for measured_cp) as a 4x4."""
    T = np.eye(4)
    for i in range(3):
        T[i, 3] = frame.p[i]
        for j in range(3):
            T[i, j] = frame.M[i, j]
    return T


def drive(policy_path: str, target, hold: float, arm_name: str = "PSM1") -> dict:
    """Runs one episode of the policy on the arm; returns what happened."""
    import crtk
    import dvrk

    from cressim.envs.tissue_retract import JAW_OPEN
    from cressim.envs.tissue_retract_client import TissueRetractClient
    from cressim.learn.policy import load_policy

    policy = load_policy(policy_path)
    if policy.task != "TissueRetract" or policy.task_options.get("observation") != "crtk":
        raise SystemExit(f"{policy_path}: a policy of {policy.task} {policy.task_options}, not TissueRetract with "
                         f"observation=crtk")
    ral = crtk.ral("cressim_sim_to_real")
    result = {}

    def run():
        # a reading may be seconds old on a loaded CPU-only machine (the twin's ticks then take
        # seconds; a make test beside two busy processes saw 5 s), past the client's default 5 s
        psm = dvrk.psm(ral, arm_name, connection_timeout=60.0)
        ral.check_connections(60.0)
        if not (psm.enable(60.0) and psm.home(60.0)):
            raise SystemExit(f"! enable/home failed: {psm.operating_state()}")
        client = TissueRetractClient(target)
        if not psm.move_jp(client.q).wait(timeout=60.0) or not psm.jaw.move_jp(np.array([JAW_OPEN])).wait(timeout=60.0):
            raise SystemExit("! the move to the start pose did not finish")
        _, last = psm.setpoint_cp()
        sent = client.q
        closed_at, was_closed, lift, success = None, False, 0.0, False
        for step in range(MAX_STEPS):
            # the next step: 1/60 s of the arm's clock after the last, once the arm has taken the last
            # command (setpoint_js at it) and setpoint_cp is from then on. The policy sees the pose
            # commanded, as the batched task's kinematic arm is at its joint targets; measured_cp
            # trails it (the twin's measured lag, a real arm's tracking), a delay the policy never saw
            while True:
                jp, jp_stamp = psm.setpoint_jp()
                frame, stamp = psm.setpoint_cp()
                if stamp >= last + STEP - 1e-4 and stamp >= jp_stamp and np.allclose(jp[:6], sent, atol=1e-6):
                    break
                time.sleep(0.001)
            last = stamp
            obs = client.observation(frame_matrix(frame))
            q, jaw = client.act(policy(obs).numpy())
            sent = q
            psm.servo_jp(q)
            psm.jaw.servo_jp(np.array([jaw]))
            if obs[27] > 0 and (closed_at is None or not was_closed):
                closed_at = step  # the last closing: the lift counts from there
            was_closed = obs[27] > 0
            lift = float(obs[28]) * client.target_lift if was_closed else 0.0
            if obs[27] > 0 and obs[28] >= 1.0:
                success = True
                break
        settle = psm.measured_cp()[1]
        while psm.measured_cp()[1] < settle + hold:  # hold still (the arm's clock) and read the load
            time.sleep(0.005)
        force, _ = psm.spatial.measured_cf()
        result.update(steps=step + 1, closed_at=closed_at, success=success, lift_m=lift,
                      force_n=[float(f) for f in force[:3]])
        psm.jaw.move_jp(np.array([JAW_OPEN])).wait(timeout=60.0)

    ral.spin_and_execute(run)
    return result


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--policy", required=True, help="a checkpoint of `cressim train TissueRetract` (observation=crtk)")
    p.add_argument("--target", type=float, nargs=3, default=MIDDLE_OF_FREE_EDGE, metavar=("X", "Y", "Z"),
                   help="the point to grasp, in the twin's world (m)")
    p.add_argument("--hold", type=float, default=0.5, help="s to hold the flap up before reading the force")
    p.add_argument("--twin", action="store_true", help="start the twin (psm_retraction.yaml) for the run")
    args = p.parse_args(argv)
    clients = dvrk_clients()
    sys.path[:0] = [str(clients / "crtk_python_client" / "src"), str(clients / "dvrk_python" / "src")]
    os.environ.setdefault("ROS_VERSION", "2")
    twin = None
    if args.twin:
        from cressim_ros.twin_process import Twin

        domain = int(os.environ.get("ROS_DOMAIN_ID", 1 + os.getpid() % 100))
        os.environ.update(ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
        twin = Twin(domain, Path("sim_to_real_twin.log").resolve(), "scene:=psm_retraction.yaml")
        twin.wait_ready()
    try:
        result = drive(args.policy, args.target, args.hold)
    finally:
        if twin is not None:
            twin.stop()
    print(f"{'success' if result['success'] else 'no success'} after {result['steps']} steps: the jaws last closed at "
          f"step {result['closed_at']}, the tool rose {result['lift_m'] * 1e3:.1f} mm since, force on the tool "
          f"{np.round(result['force_n'], 3).tolist()} N")
    return 0 if result["success"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
