"""Batched rollouts recorded to rosbag2 MCAP bags: `cressim generate TASK --envs N --steps K`.

Each process (one, or one a GPU under torchrun: `--nproc P`) runs its shard of the envs
(learn/distributed.py) and writes its own bag, OUT/shard_<rank>; rank 0 then writes
OUT/index.json, which names every shard, its envs and its message counts. Every step k, each bag
gets, at the simulated time k * dt:

    /rollout/observation   std_msgs/Float32MultiArray (UInt8MultiArray for image tasks)  [env, *obs]
    /rollout/action        std_msgs/Float32MultiArray  [env, *action]: what the policy did at k
    /rollout/reward        std_msgs/Float32MultiArray  [env]: what step k paid
    /rollout/terminated    std_msgs/UInt8MultiArray    [env]: 1 where step k ended the episode
    /rollout/truncated     std_msgs/UInt8MultiArray    [env]: 1 where it ran out of time

The observation is the one the action was taken on. Envs reset within the step that ends their
episode, so the observation at k + 1 of an env that terminated at k is its next episode's first.
The layout's dims are labelled ("env", then "obs0", "obs1"... or "action0"...), row-major,
as ROS's MultiArrayLayout defines them. The actions come from a checkpoint's mean policy
(`policy`) or are uniform in [-1, 1] (every task's action range), drawn for the whole batch
from `seed` so that the shards act as one process with every env would.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import torch

from cressim.learn import distributed

TOPICS = ("observation", "action", "reward", "terminated", "truncated")


def _array(values: torch.Tensor, label: str) -> tuple[dict, str]:
    """A batch (env, ...) as a std_msgs MultiArray message dict and its type."""
    a = values.detach().cpu().numpy()
    uint8 = a.dtype in (np.uint8, np.bool_)
    dims, stride = [], int(a.size)
    for i, size in enumerate(a.shape):
        dims.append({"label": "env" if i == 0 else f"{label}{i - 1}", "size": int(size), "stride": stride})
        stride //= max(int(size), 1)
    data = np.ascontiguousarray(a, dtype=np.uint8 if uint8 else np.float32).ravel()
    msgtype = "std_msgs/msg/UInt8MultiArray" if uint8 else "std_msgs/msg/Float32MultiArray"
    return {"layout": {"dim": dims, "data_offset": 0}, "data": data}, msgtype


def generate(task: str, num_envs: int, steps: int, out_dir, *, policy=None, seed: int = 0,
             task_options: dict | None = None, device=None) -> dict:
    """Records `steps` steps of `num_envs` envs of `task`; returns the index (what index.json holds)."""
    from cressim import envs
    from cressim.learn.policy import load_policy
    from cressim.record.writer import BagWriter

    if steps < 1:
        raise ValueError(f"steps must be >= 1, got {steps}")
    shard, env_device, vulkan = distributed.place(device)
    count, offset = shard.envs(num_envs)
    out = Path(out_dir)
    bag_dir = out / f"shard_{shard.rank:03d}"
    if bag_dir.exists():
        raise FileExistsError(f"{bag_dir} exists: generate into a new folder")
    out.mkdir(parents=True, exist_ok=True)
    env = envs.make(task, num_envs=count, device=env_device, seed=seed, env_offset=offset, vulkan_device=vulkan,
                    **(task_options or {}))
    actor = load_policy(policy, env.device) if policy else None
    if actor is not None and actor.task != task:
        raise ValueError(f"policy {policy} was trained on {actor.task}, not {task}")
    noise = torch.Generator(env.device)
    noise.manual_seed(seed)
    dt = env.engine.physics.dt
    dt_ns = round(dt * 1e9)
    action_shape = tuple(env.single_action_space.shape)
    obs, _ = env.reset()
    with BagWriter(bag_dir, on_full="block", custom_data={"cressim.task": task, "cressim.first_env": str(offset)}) as bag:
        for k in range(steps):
            if actor is not None:
                actions = actor(obs.reshape(count, -1))
            else:  # the whole batch's draw, this shard's rows
                draw = torch.rand((shard.world * count, *action_shape), generator=noise, device=env.device)
                actions = 2 * draw[offset:offset + count] - 1
            t = k * dt_ns
            for name, values in (("observation", obs), ("action", actions)):
                msg, msgtype = _array(values, "obs" if name == "observation" else "action")
                bag.write(f"/rollout/{name}", msg, msgtype=msgtype, log_time=t)
            obs, reward, terminated, truncated, _ = env.step(actions)
            for name, values in (("reward", reward), ("terminated", terminated), ("truncated", truncated)):
                msg, msgtype = _array(values, name)
                bag.write(f"/rollout/{name}", msg, msgtype=msgtype, log_time=t)
    env.close()
    entry = {"rank": shard.rank, "path": bag_dir.name, "first_env": offset, "envs": count,
             "messages": {f"/rollout/{name}": steps for name in TOPICS},
             "device": str(env.device), "vulkan_device": vulkan}
    shards = distributed.gather(entry)
    index = {"task": task, "task_options": dict(task_options or {}), "num_envs": num_envs, "steps": steps, "seed": seed,
             "dt": dt, "policy": str(policy) if policy else "uniform",
             "observation_shape": list(env.single_observation_space.shape), "action_shape": list(action_shape),
             "processes": shard.world, "shards": shards}
    if shard.leader:
        (out / "index.json").write_text(json.dumps(index, indent=1))
    distributed.barrier()  # the index is written before any process returns
    return index


def read_shard(bag: Path, envs: int) -> dict:
    """One shard's topics as arrays (steps, envs, ...), read with rosbags (an independent reader)."""
    from rosbags.highlevel import AnyReader

    series: dict = {name: [] for name in TOPICS}
    with AnyReader([Path(bag)]) as reader:
        for connection, _, raw in reader.messages(connections=reader.connections):
            msg = reader.deserialize(raw, connection.msgtype)
            sizes = [d.size for d in msg.layout.dim]
            series[connection.topic.rsplit("/", 1)[1]].append(np.asarray(msg.data).reshape(sizes))
    out = {name: np.stack(v) for name, v in series.items() if v}
    for name, v in out.items():
        if v.shape[1] != envs:
            raise ValueError(f"{bag}: /rollout/{name} holds {v.shape[1]} envs, the index says {envs}")
    return out


def read(out_dir) -> dict:
    """A generated folder's rollouts, the shards joined along the env axis: arrays (steps, envs, ...)."""
    out = Path(out_dir)
    index = json.loads((out / "index.json").read_text())
    shards = sorted(index["shards"], key=lambda s: s["first_env"])
    parts = [read_shard(out / s["path"], s["envs"]) for s in shards]
    joined = {name: np.concatenate([p[name] for p in parts], axis=1) for name in parts[0]}
    if joined["observation"].shape[:2] != (index["steps"], index["num_envs"]):
        raise ValueError(f"{out}: the shards hold {joined['observation'].shape[:2]} (steps, envs), "
                         f"the index says ({index['steps']}, {index['num_envs']})")
    return joined
