"""Every test runs with the Vulkan validation layer on and fails on any message it reports."""
import os

os.environ.setdefault("CRESSIM_VALIDATION", "1")

import pytest  # noqa: E402

import cressim  # noqa: E402


@pytest.fixture
def make_engine():
    """make_engine(world) -> Engine; checks, after the test, that validation stayed silent."""
    engines = []

    def make(world, **kwargs):
        engine = cressim.Engine(world, **kwargs)
        engines.append(engine)
        return engine

    yield make
    for engine in engines:
        assert engine.validation_enabled, "validation layer did not load (vulkan-validationlayers)"
        assert engine.validation_messages == [], "\n".join(engine.validation_messages)


@pytest.fixture
def small_world():
    """4 envs, entities created interleaved across envs, positions encoding (env, index)."""
    world = cressim.World(cressim.SceneLayout(4))
    for i in range(12):
        env = i % 4
        world.create_entity(env=env, name=f"body{i}").add(cressim.Transform(position=(env, i, 0.5)))
    return world
