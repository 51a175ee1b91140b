"""Zero-copy torch views: CPU memory on lavapipe (always tested), CUDA memory on NVIDIA
(run on the GPU machine; skipped where the Vulkan device cannot share memory with CUDA)."""
import numpy as np
import pytest
import torch

import cressim

DOUBLE = """
StructuredBuffer<float> src; RWStructuredBuffer<float> dst;
[numthreads(64,1,1)] void main(uint3 id : SV_DispatchThreadID) { if (id.x < 4096) dst[id.x] = 2 * src[id.x]; }
"""


def engine_with_buffers(make_engine):
    world = cressim.World(cressim.SceneLayout(1))
    engine = make_engine(world)
    engine.prepare()
    engine.upload_world()
    src = engine.create_shared_buffer("src", 4096)
    dst = engine.create_shared_buffer("dst", 4096)
    p = engine.create_compute_pass(DOUBLE, name="double", threads=4096, bindings={"src": src, "dst": dst})
    return engine, src, dst, p


def test_cpu_tensors_share_host_visible_memory(make_engine):
    engine, src, dst, p = engine_with_buffers(make_engine)
    if not src.host_visible:
        pytest.skip("device memory is not host-visible here")
    s, d = torch.from_dlpack(src), torch.from_dlpack(dst)
    assert s.device.type == "cpu"
    s.copy_(torch.arange(4096, dtype=torch.float32))
    engine.execute_compute_pass(p)
    engine.end_frame()
    assert torch.equal(d, 2 * torch.arange(4096, dtype=torch.float32))


def test_cuda_tensors_share_vulkan_memory_with_stream_sync(make_engine):
    world = cressim.World(cressim.SceneLayout(1))
    probe = make_engine(world)
    if not (torch.cuda.is_available() and probe.cuda_interop["available"]):
        pytest.skip(f"no CUDA zero-copy here: {probe.cuda_interop['reason'] or 'torch has no CUDA'}")
    engine, src, dst, p = engine_with_buffers(make_engine)
    assert src.cuda_shareable
    s, d = torch.from_dlpack(src), torch.from_dlpack(dst)
    assert s.device.type == "cuda" and d.device.type == "cuda"
    engine.cuda_stream = torch.cuda.current_stream().cuda_stream
    for k in range(1, 6):
        # written on the torch stream, read by the Vulkan frame without a host sync in between
        s.copy_(torch.arange(4096, device="cuda", dtype=torch.float32) * k)
        engine.execute_compute_pass(p)
        engine.end_frame()
        assert torch.equal(d, 2 * k * torch.arange(4096, device="cuda", dtype=torch.float32))
    np.testing.assert_array_equal(dst.read(), d.cpu().numpy())  # the same memory, read through Vulkan
