"""Torch devices as the envs want them, and waiting for their queued work: below both the
rollout loop and the process placement (distributed.py), which each need them."""
from __future__ import annotations

import torch


def resolve_device(device):
    """None stays None (the env picks); a bare "cuda" gets the current index, because the env
    compares its buffers' device (always indexed) with this one."""
    if device is None:
        return None
    device = torch.device(device)
    if device.type == "cuda" and device.index is None:
        device = torch.device("cuda", torch.cuda.current_device())
    return device


def sync(device) -> None:
    """Waits for the torch work queued on `device` (env.step already waits for Vulkan)."""
    if torch.device(device).type == "cuda":
        torch.cuda.synchronize(device)
