"""A function replayed as one CUDA graph after a few eager calls.

The learner's networks are small: on a GPU a policy step or a minibatch update is a few dozen
kernels of microseconds each, and Python plus torch's dispatcher spend far longer launching
them (the H100 profile of TargetCenter's PPO: 7 ms of host time per minibatch for 2 ms of GPU
work). Replaying a captured graph launches them all at once. The function must read and
write only tensors whose storage stays put between calls (static inputs copied in first);
anything it allocates comes from the graph's own memory pool and is reused by every replay.
"""
from __future__ import annotations

from typing import Callable

import torch


class Captured:
    """Calls `fn()` eagerly `warmup` times (on a side stream, so that lazy initialisation of
    cuDNN, cuBLAS and the optimizer's state is done before capture), then captures it once and
    from then on replays the graph and returns the outputs of the captured call. Off CUDA it
    just calls `fn()`, as it does where `enabled` is False."""

    def __init__(self, fn: Callable, device: torch.device, warmup: int = 3, enabled: bool = True):
        self.fn, self.warmup = fn, warmup
        self.enabled = enabled and torch.device(device).type == "cuda"
        self.graph, self.outputs, self.calls = None, None, 0

    def __call__(self):
        if not self.enabled:
            return self.fn()
        if self.graph is None and self.calls < self.warmup:
            self.calls += 1
            side = torch.cuda.Stream()
            side.wait_stream(torch.cuda.current_stream())
            with torch.cuda.stream(side):
                out = self.fn()
            torch.cuda.current_stream().wait_stream(side)
            return out
        if self.graph is None:
            self.graph = torch.cuda.CUDAGraph()
            with torch.cuda.graph(self.graph):
                self.outputs = self.fn()  # recorded, not run: the replay below runs it
        self.graph.replay()
        return self.outputs
