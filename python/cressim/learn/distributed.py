"""Several processes, one engine each, through torch.distributed (started by torchrun or by
`cressim train --nproc N`, which runs torchrun).

Each process steps its shard of the envs on its own GPU: the Vulkan device whose UUID is its
CUDA device's (LOCAL_RANK), or lavapipe on a machine without CUDA. The shards are one batch split
in rank order: process r runs envs [r n, (r + 1) n) of it (`VectorEnv(env_offset=...)`), so the
processes together draw exactly the random numbers one process with all the envs would.
Collectives go over NCCL between GPUs and gloo on CPUs. Code that sums across processes calls
`all_sum`, which does nothing in a single process: one code path either way.
"""
from __future__ import annotations

import os
import re
from dataclasses import dataclass

import torch
import torch.distributed as dist

import cressim

from .device import resolve_device


@dataclass(frozen=True)
class Shard:
    """This process's place: rank among `world` processes, and its GPU on this host (local)."""
    rank: int = 0
    world: int = 1
    local: int = 0

    def envs(self, total: int) -> tuple[int, int]:
        """(count, offset) of this process's envs out of `total`, which must split evenly."""
        if total % self.world:
            raise ValueError(f"{total} envs do not split evenly over {self.world} processes; "
                             f"use a multiple of {self.world}")
        count = total // self.world
        return count, self.rank * count

    @property
    def leader(self) -> bool:
        """Rank 0: the one that prints and writes checkpoints and indexes."""
        return self.rank == 0


def launched() -> bool:
    """Started by torchrun (or an equivalent launcher) with more than one process."""
    return int(os.environ.get("WORLD_SIZE", "1")) > 1


def start(device: str | None = None) -> tuple[Shard, torch.device]:
    """Joins the process group torchrun describes (a no-op in a single process); returns this
    process's shard and its torch device: cuda:LOCAL_RANK where CUDA is (unless `device` says
    cpu), else the cpu. Idempotent."""
    shard = Shard(int(os.environ.get("RANK", "0")), int(os.environ.get("WORLD_SIZE", "1")),
                  int(os.environ.get("LOCAL_RANK", "0")))
    wanted = torch.device(device) if device is not None else None
    cuda = torch.cuda.is_available() and (wanted is None or wanted.type == "cuda")
    if wanted is not None and wanted.type not in ("cuda", "cpu"):
        raise ValueError(f"device {device!r}: distributed training runs on 'cuda' or 'cpu'")
    if cuda and shard.local >= torch.cuda.device_count():
        raise RuntimeError(f"process {shard.rank} wants CUDA device {shard.local} (LOCAL_RANK), but this host "
                           f"has {torch.cuda.device_count()}; start at most that many processes per host")
    torch_device = torch.device("cuda", shard.local) if cuda else torch.device("cpu")
    if shard.world > 1 and not dist.is_initialized():
        if cuda:
            torch.cuda.set_device(torch_device)
        dist.init_process_group("nccl" if cuda else "gloo", device_id=torch_device if cuda else None)
    return shard, torch_device


def place(device: str | None = None) -> tuple[Shard, torch.device | None, str | None]:
    """Where this process runs its envs: (shard, torch device, Vulkan device). Launched: `start`'s
    shard and device, and the Vulkan device of that CUDA device; alone: the whole batch on
    `device` (None: the env picks) and the default Vulkan device."""
    if not launched():
        return Shard(), resolve_device(device), None
    shard, d = start(device)
    return shard, d, vulkan_device_of(d.index) if d.type == "cuda" else None


def stop() -> None:
    if dist.is_initialized():
        dist.destroy_process_group()


def active() -> bool:
    return dist.is_available() and dist.is_initialized() and dist.get_world_size() > 1


def all_sum(t: torch.Tensor) -> torch.Tensor:
    """`t` summed over the processes, in place (itself in a single process)."""
    if active():
        dist.all_reduce(t)
    return t


def broadcast(tensors) -> None:
    """Rank 0's values of `tensors` on every process, in place."""
    if active():
        for t in tensors:
            dist.broadcast(t.data, 0)


def average_gradients(params) -> None:
    """The gradients of `params` averaged over the processes, in place: one all-reduce of them
    all, flattened. Not DistributedDataParallel: the learner replays its minibatch step as a CUDA
    graph (cuda_graph.py), and an NCCL all-reduce can be captured in one where DDP's reducer
    (autograd hooks, buckets rebuilt after the first step) cannot be relied on to."""
    if not active():
        return
    grads = [p.grad for p in params if p.grad is not None]
    flat = torch.cat([g.reshape(-1) for g in grads])
    dist.all_reduce(flat)
    flat /= dist.get_world_size()
    offset = 0
    for g in grads:
        g.copy_(flat[offset:offset + g.numel()].view_as(g))
        offset += g.numel()


def barrier() -> None:
    if active():
        dist.barrier()


def gather(value) -> list:
    """Every process's `value` (a picklable object), in rank order, on every process."""
    if not active():
        return [value]
    out = [None] * dist.get_world_size()
    dist.all_gather_object(out, value)
    return out


def vulkan_device_of(cuda_index: int) -> str:
    """The index (as CRESSIM_DEVICE takes it) of the Vulkan device that is CUDA device
    `cuda_index`: the one with the same UUID, since a host's identical GPUs share a name and the
    two APIs need not number them alike."""
    uuid = re.sub(r"[^0-9a-f]", "", str(torch.cuda.get_device_properties(cuda_index).uuid).lower())
    devices = cressim.list_devices()
    for d in devices:
        if d["uuid"] == uuid:
            return str(d["index"])
    names = ", ".join(f"{d['index']}: {d['name']} {d['uuid']}" for d in devices)
    raise RuntimeError(f"no Vulkan device has the UUID {uuid} of CUDA device {cuda_index}; Vulkan devices: {names}")
