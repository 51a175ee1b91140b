"""cressim.read_buffers: several buffers into the caller's arrays in one submit (a camera frame's
products at once), the arrays reused; wrong arrays are refused naming the buffer."""
import numpy as np
import pytest

import cressim


def test_buffers_come_back_into_the_given_arrays(make_engine):
    world = cressim.World(cressim.SceneLayout(1))
    world.create_entity(env=0).add(cressim.Transform(position=(0.1, 0.2, 0.3)))
    engine = make_engine(world)
    engine.prepare()
    engine.upload_world()
    a = engine.create_shared_buffer("a", (3, 4), "float32")
    b = engine.create_shared_buffer("b", 5, "uint32")
    a.write(np.arange(12, dtype=np.float32).reshape(3, 4))
    b.write(np.array([7, 8, 9, 10, 11], dtype=np.uint32))
    positions = engine.buffer("transform.positions")
    outs = [np.zeros((3, 4), np.float32), np.zeros(5, np.uint32), np.zeros(positions.shape, positions.dtype)]
    cressim.read_buffers([a, b, positions], outs)
    assert np.array_equal(outs[0], np.arange(12).reshape(3, 4)) and np.array_equal(outs[1], [7, 8, 9, 10, 11])
    assert np.allclose(outs[2], positions.read()) and np.allclose(outs[2].reshape(-1)[:3], [0.1, 0.2, 0.3])
    first = outs[0]
    a.write(np.full((3, 4), 2.5, np.float32))
    cressim.read_buffers([a], [first])  # the same array again: overwritten in place
    assert np.all(first == 2.5)
    with pytest.raises(ValueError, match=r"read_buffers: the array for 'b' \(5,\) uint32 has 16 bytes, the buffer 20"):
        cressim.read_buffers([b], [np.zeros(4, np.uint32)])
    with pytest.raises(ValueError, match="not a writeable C-contiguous array"):
        cressim.read_buffers([a], [np.zeros((4, 3), np.float32).T])
    with pytest.raises(ValueError, match="2 buffers but 1 arrays"):
        cressim.read_buffers([a, b], [first])
