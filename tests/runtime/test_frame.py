import numpy as np
import pytest

import cressim

# one step of a per-element recurrence: state <- state * 0.5 + frame-independent input
STEP = """
struct Params { uint n; };
[[vk::push_constant]] ConstantBuffer<Params> pc;
StructuredBuffer<float> inputs;
RWStructuredBuffer<float> state;
[numthreads(64,1,1)] void main(uint3 id : SV_DispatchThreadID) {
  if (id.x < pc.n) state[id.x] = state[id.x] * 0.5 + inputs[id.x];
}
"""
COUNT = """
RWStructuredBuffer<uint> counter;
[numthreads(1,1,1)] void main() { counter[0] += 1; }
"""


def setup(make_engine, n=256):
    world = cressim.World(cressim.SceneLayout(2))
    world.create_entity(env=0).add(cressim.Transform())
    engine = make_engine(world)
    engine.prepare()
    engine.upload_world()
    inputs = engine.create_shared_buffer("inputs", n)
    inputs.write(np.linspace(0, 1, n, dtype=np.float32))
    state = engine.create_shared_buffer("state", n)
    step = engine.create_compute_pass(STEP, name="step", threads=n, constants={"n": n},
                                      bindings={"inputs": inputs, "state": state})
    return engine, state, step


def test_steady_state_frame_is_recorded_once_and_replayed(make_engine):
    engine, state, step = setup(make_engine)
    for _ in range(10):
        engine.step_physics()
        engine.execute_compute_pass(step)
        engine.end_frame()
    assert engine.recorded_frames == 1
    assert engine.submits == 10 and engine.frame_count == 10


def test_replayed_frame_equals_freshly_recorded_frame(make_engine):
    replay_engine, replayed, step = setup(make_engine)
    for _ in range(8):
        replay_engine.execute_compute_pass(step)
        replay_engine.end_frame()
    fresh_engine, fresh, fresh_step = setup(make_engine)
    for i in range(8):
        fresh_step.set_constant("n", 256)  # bumps the pass version: every frame is re-recorded
        fresh_engine.execute_compute_pass(fresh_step)
        fresh_engine.end_frame()
    assert replay_engine.recorded_frames == 1 and fresh_engine.recorded_frames == 8
    assert np.array_equal(replayed.read(), fresh.read())


def test_passes_run_in_the_order_given_and_frame_shapes_are_cached(make_engine):
    engine, state, step = setup(make_engine)
    counter = engine.create_shared_buffer("counter", 1, "uint32")
    count = engine.create_compute_pass(COUNT, name="count", dispatch=(1, 1, 1), bindings={"counter": counter})
    for i in range(6):  # alternate two frame shapes: each is recorded once
        engine.execute_compute_pass(count)
        if i % 2:
            engine.execute_compute_pass(count)
        engine.end_frame()
    assert counter.read()[0] == 9
    assert engine.recorded_frames == 2


def test_reset_requests_reach_only_flagged_envs(make_engine):
    world = cressim.World(cressim.SceneLayout(3))
    for env in range(3):
        world.create_entity(env=env).add(cressim.Transform(position=(env, 0, 0)))
    engine = make_engine(world)
    engine.prepare()
    engine.upload_world()
    # a task pass flags env 1 through the engine's writable reset mask
    flag = engine.create_compute_pass("RWStructuredBuffer<uint> mask; [numthreads(1,1,1)] void main() { mask[1] = 1; }",
                                      name="flag", dispatch=1, bindings={"mask": "env.reset_mask"})
    engine.execute_compute_pass(flag)
    engine.end_frame()
    assert list(engine.buffer("env.reset_count").read()) == [0, 0, 0]
    engine.end_frame()  # the reset stage runs first in the next frame, then clears the flags
    assert list(engine.buffer("env.reset_count").read()) == [0, 1, 0]
    assert list(engine.buffer("env.reset_mask").read()) == [0, 0, 0]
    engine.reset_envs([2])  # and the host asks for env 2
    engine.end_frame()
    assert list(engine.buffer("env.reset_count").read()) == [0, 1, 1]
    assert np.array_equal(engine.buffer("transform.positions").read(),
                          engine.buffer("transform.initial_positions").read())
    with pytest.raises(IndexError, match="env 3 is out of range"):
        engine.reset_envs([3])


def test_profiling_times_every_stage(make_engine):
    engine, state, step = setup(make_engine)
    engine.profiling = True
    engine.step_physics()
    engine.execute_compute_pass(step)
    engine.end_frame()
    labels = [label for label, ms in engine.last_timings]
    assert labels == ["upload", "step_physics", "pass 'step'"]
    assert all(ms >= 0 for _, ms in engine.last_timings)


def test_pass_profiling_names_every_pass_and_adds_up_to_the_ops(make_engine):
    engine, state, step = setup(make_engine)
    count = engine.create_compute_pass(COUNT, name="count", dispatch=(1, 1, 1),
                                       bindings={"counter": engine.create_shared_buffer("counter", 1, "uint32")})
    engine.profiling = True
    engine.end_frame()
    assert engine.last_pass_timings == []  # passes are timed only when asked for
    engine.profile_passes = True
    engine.execute_compute_pass(step)
    engine.execute_compute_pass(count)
    engine.execute_compute_pass(step)
    engine.end_frame()
    passes = engine.last_pass_timings
    assert [(op, name) for op, name, _ in passes if name != "(rest)"] == [
        ("upload", "scene/reset_envs"), ("pass 'step'", "step"), ("pass 'count'", "count"), ("pass 'step'", "step")]
    assert all(ms >= 0 for *_, ms in passes)
    for label in {op for op, _ in engine.last_timings}:  # an op's time is its passes' and what followed them
        assert sum(ms for op, _, ms in passes if op == label) == pytest.approx(
            sum(ms for op, ms in engine.last_timings if op == label), abs=1e-9)
    engine.profile_passes = False
    engine.end_frame()
    assert [label for label, _ in engine.last_timings] == ["upload"]
