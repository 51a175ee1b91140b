import textwrap

import numpy as np
import pytest

import cressim

ENVS, N = 64, 1000

# out[env, i] = a * x[env, i] + offset of env's first entity row (read from an internal buffer)
SAXPY = textwrap.dedent("""
    struct Params { uint envs; uint n; float a; };
    [[vk::push_constant]] ConstantBuffer<Params> pc;
    StructuredBuffer<uint> env_offset;
    StructuredBuffer<float> x;
    RWStructuredBuffer<float> out_values;

    [numthreads(64, 1, 1)]
    void main(uint3 id : SV_DispatchThreadID) {
      if (id.x >= pc.envs * pc.n) return;
      uint env = id.x / pc.n;
      out_values[id.x] = pc.a * x[id.x] + float(env_offset[env]);
    }
""")


@pytest.fixture
def world64():
    world = cressim.World(cressim.SceneLayout(ENVS))
    for env in range(ENVS):
        for _ in range(env % 3):
            world.create_entity(env=env).add(cressim.Transform())
    return world


def test_user_pass_over_64_envs_equals_numpy(make_engine, world64):
    engine = make_engine(world64)
    engine.prepare()
    engine.upload_world()
    x = engine.create_shared_buffer("x", (ENVS, N), "float32")
    out = engine.create_shared_buffer("out", (ENVS, N), "float32")
    xs = np.random.default_rng(0).uniform(-1, 1, (ENVS, N)).astype(np.float32)
    x.write(xs)
    p = engine.create_compute_pass(SAXPY, name="saxpy", threads=ENVS * N,
                                   bindings={"env_offset": "env.entity_offset", "x": x, "out_values": "out"},
                                   constants={"envs": ENVS, "n": N, "a": 2.5})
    assert p.local_size == [64, 1, 1] and p.groups[0] == (ENVS * N + 63) // 64
    engine.execute_compute_pass(p)
    engine.end_frame()
    offsets = engine.mapping["env_offset"].astype(np.float32)
    np.testing.assert_allclose(out.read(), 2.5 * xs + offsets[:, None], rtol=1e-6, atol=1e-6)  # fma or not


def test_bad_hlsl_reports_the_line(make_engine, world64):
    engine = make_engine(world64)
    bad = "RWStructuredBuffer<float> o;\n[numthreads(1,1,1)]\nvoid main() {\n  o[0] = undefined_name;\n}\n"
    with pytest.raises(cressim.ShaderCompileError, match=r"my_pass:4: error.*undefined_name"):
        engine.create_compute_pass(bad, name="my_pass", threads=1, bindings={})


def test_unknown_key_lists_the_valid_keys(make_engine, world64):
    engine = make_engine(world64)
    engine.prepare()
    engine.upload_world()
    with pytest.raises(cressim.BindingError, match=r"unknown buffer key 'rigid.positions'.*transform\.positions"):
        engine.create_compute_pass(SAXPY, name="p", threads=1,
                                   bindings={"env_offset": "rigid.positions", "x": "a", "out_values": "b"})


def test_missing_and_extra_bindings_are_named(make_engine, world64):
    engine = make_engine(world64)
    engine.prepare()
    engine.upload_world()
    out = engine.create_shared_buffer("out", 8)
    with pytest.raises(cressim.BindingError, match="no buffer bound to shader buffer.*env_offset, x;"):
        engine.create_compute_pass(SAXPY, name="p", threads=1, bindings={"out_values": out})
    with pytest.raises(cressim.BindingError, match="'typo'.*does not declare; its buffers are: env_offset, out_values, x"):
        engine.create_compute_pass(SAXPY, name="p", threads=1,
                                   bindings={"typo": out, "x": out, "env_offset": out, "out_values": out})


def test_internal_buffers_are_read_only_in_passes(make_engine, world64):
    engine = make_engine(world64)
    engine.prepare()
    engine.upload_world()
    writer = "RWStructuredBuffer<float4> p;\n[numthreads(1,1,1)] void main() { p[0] = 0; }\n"
    with pytest.raises(cressim.BindingError, match="may only read"):
        engine.create_compute_pass(writer, name="w", threads=1, bindings={"p": "transform.positions"})
    # unless the pass names that key in internal_writes (domain randomization writes model buffers)
    with pytest.raises(cressim.BindingError, match="may only read"):
        engine.create_compute_pass(writer, name="w", threads=1, bindings={"p": "transform.positions"},
                                   internal_writes=["transform.rotations"])
    w = engine.create_compute_pass(writer, name="w", threads=1, bindings={"p": "transform.positions"},
                                   internal_writes=["transform.positions"])
    engine.execute_compute_pass(w)
    engine.end_frame()
    assert (engine.buffer("transform.positions").read()[0] == 0).all()
    positions = engine.buffer("transform.positions")
    if positions.host_visible:  # and where numpy can view it, the view is read-only too
        assert not np.from_dlpack(positions).flags.writeable


def test_unknown_constant_and_dispatch_errors(make_engine, world64):
    engine = make_engine(world64)
    engine.prepare()
    engine.upload_world()
    bufs = {"env_offset": "env.entity_offset", "x": engine.create_shared_buffer("x", 1),
            "out_values": engine.create_shared_buffer("o", 1)}
    with pytest.raises(cressim.BindingError, match="no push constant 'b'; its constants are: a, envs, n"):
        engine.create_compute_pass(SAXPY, name="p", threads=1, bindings=bufs, constants={"b": 1})
    with pytest.raises(ValueError, match="exactly one of dispatch"):
        engine.create_compute_pass(SAXPY, name="p", bindings=bufs)


def test_pass_from_file_resolves_includes(make_engine, world64, tmp_path):
    (tmp_path / "scale.h").write_text("static const float SCALE = 3.0;\n")
    (tmp_path / "pass.hlsl").write_text(
        '#include "scale.h"\n#include "cressim/layout.h"\nRWStructuredBuffer<float> o;\n'
        "[numthreads(CRESSIM_GROUP_SIZE,1,1)] void main(uint3 id : SV_DispatchThreadID) {\n"
        "  if (id.x < 4) o[id.x] = SCALE * id.x;\n}\n")
    engine = make_engine(world64)
    engine.prepare()
    engine.upload_world()
    out = engine.create_shared_buffer("o", 4)
    p = cressim.load_compute_pass(engine, tmp_path / "pass.hlsl", bindings={"o": out}, threads=4)
    engine.execute_compute_pass(p)
    engine.end_frame()
    assert list(out.read()) == [0, 3, 6, 9]
