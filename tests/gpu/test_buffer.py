import numpy as np
import pytest


def test_round_trip_of_a_million_floats(make_engine, small_world):
    engine = make_engine(small_world)
    buf = engine.create_shared_buffer("big", 1_000_000, "float32")
    values = np.random.default_rng(1).standard_normal(1_000_000).astype(np.float32)
    buf.write(values)
    assert np.array_equal(buf.read(), values)


def test_shared_buffer_starts_zeroed_and_keeps_shape_and_dtype(make_engine, small_world):
    engine = make_engine(small_world)
    buf = engine.create_shared_buffer("grid", (3, 5), np.int32)
    assert buf.shape == (3, 5) and buf.dtype == np.int32 and buf.nbytes == 60
    assert np.array_equal(buf.read(), np.zeros((3, 5), np.int32))


def test_host_visible_buffer_is_viewed_without_copy(make_engine, small_world):
    engine = make_engine(small_world)
    buf = engine.create_shared_buffer("view", (2, 3), "float32")
    if not buf.host_visible:
        pytest.skip("device memory is not host-visible on this device")
    view = np.from_dlpack(buf)
    view[1, 2] = 7.0  # writes through to the GPU buffer
    assert buf.read()[1, 2] == 7.0
    assert np.shares_memory(view, buf.numpy())


def test_write_of_wrong_size_is_refused(make_engine, small_world):
    engine = make_engine(small_world)
    buf = engine.create_shared_buffer("small", 4, "float32")
    with pytest.raises(ValueError, match="got 5 elements, need 4"):
        buf.write(np.zeros(5))


def test_bad_names_and_dtypes_are_refused(make_engine, small_world):
    engine = make_engine(small_world)
    engine.create_shared_buffer("a", 1)
    with pytest.raises(ValueError, match="taken"):
        engine.create_shared_buffer("a", 1)
    with pytest.raises(ValueError, match="reserved"):
        engine.create_shared_buffer("my.buffer", 1)
    with pytest.raises(ValueError, match="unsupported dtype"):
        engine.create_shared_buffer("b", 1, "complex64")
