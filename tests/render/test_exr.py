"""save_exr against an independent reader (the OpenEXR package, a test dependency): colour as
half, depth as float32 metres with +inf where nothing was hit, ZIP and uncompressed; and a
camera's tensors written through it."""
import numpy as np
import pytest

import cressim
from cressim import io

OpenEXR = pytest.importorskip("OpenEXR")


def read(path):
    with OpenEXR.File(str(path)) as f:
        header = {k: v for k, v in f.header().items()}
        return header, {k: np.array(v.pixels) for k, v in f.channels().items()}


@pytest.mark.parametrize("compress", [True, False])
def test_exr_round_trip(tmp_path, compress):
    rng = np.random.default_rng(1)
    rgb = rng.integers(0, 256, (37, 21, 3), dtype=np.uint8)  # 37 rows: 16-line chunks and a partial one
    depth = rng.uniform(0.1, 5.0, (37, 21)).astype(np.float32)
    depth[3, 4] = depth[36, 20] = 0  # nothing hit
    header, ch = read(io.save_exr(tmp_path / "a.exr", rgb, depth=depth, compress=compress))
    assert header["compression"] == (OpenEXR.ZIP_COMPRESSION if compress else OpenEXR.NO_COMPRESSION)
    assert sorted(ch) == ["RGB", "Z"]
    z = ch["Z"]
    assert z.dtype == np.float32 and np.isposinf(z[3, 4]) and np.isposinf(z[36, 20])
    hit = depth > 0
    assert np.array_equal(z[hit], depth[hit])  # float32: exact
    c = ch["RGB"]
    assert c.dtype == np.float16 and c.shape == (37, 21, 3)
    # uint8 is sRGB-ish (gamma 2.2): stored linear, to half precision (relative 2^-11)
    linear = (rgb / 255.0) ** 2.2
    assert np.allclose(c.astype(np.float64), linear, rtol=1e-3, atol=1e-6)


def test_exr_float_rgba(tmp_path):
    a = np.random.default_rng(2).random((4, 6, 4)).astype(np.float32) * 10
    _, ch = read(io.save_exr(tmp_path / "f.exr", a, half=False))
    assert ch["RGBA"].dtype == np.float32 and np.array_equal(ch["RGBA"], a)


def test_exr_bad_input_names_file(tmp_path):
    with pytest.raises(ValueError, match="x.exr.*image and depth differ"):
        io.save_exr(tmp_path / "x.exr", np.zeros((4, 4, 3), np.uint8), depth=np.zeros((4, 5), np.float32))
    with pytest.raises(ValueError, match="give an image"):
        io.save_exr(tmp_path / "x.exr")


def test_camera_tensors_to_exr(tmp_path, raster, make_engine):
    world = cressim.World(cressim.SceneLayout(1))
    ball = world.create_entity(env=0, name="ball")
    ball.add(cressim.Transform())
    ball.add(cressim.Renderable(world.add_mesh(cressim.Mesh.sphere(0.5))))
    cam = world.create_entity(env=0, name="camera")
    cam.add(cressim.Transform(position=(0, 0, 3), rotation=(1.0, 0.0, 0.0, 0.0)))  # looking down -z
    cam.add(cressim.Camera(width=32, height=24, fov_y=40))
    engine = make_engine(world)
    engine.prepare()
    engine.upload_world()
    engine.step_visual_sensors()
    engine.end_frame()
    rgb, depth = engine.buffer("camera0.rgb").read()[0], engine.buffer("camera0.depth").read()[0]
    _, ch = read(io.save_exr(tmp_path / "cam.exr", rgb, depth=depth))
    assert np.isposinf(ch["Z"][0, 0])  # a corner misses the ball
    assert abs(ch["Z"][12, 16] - 2.5) < 0.02  # the ball's top, 3 - 0.5 m along the axis
    assert ch["RGBA"].shape == (24, 32, 4) and ch["RGBA"][12, 16, 0] > 0
