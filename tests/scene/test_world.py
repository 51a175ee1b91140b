import pytest

import cressim


def test_entities_belong_to_their_env():
    world = cressim.World(cressim.SceneLayout(3))
    a = world.create_entity(env=2, name="tool")
    assert (a.id, a.env, a.name) == (0, 2, "tool")
    assert "entity 0 'tool' in env 2" in repr(a)


def test_env_out_of_range_names_the_layout():
    world = cressim.World(cressim.SceneLayout(2))
    with pytest.raises(IndexError, match="env 2 is out of range .*2 envs"):
        world.create_entity(env=2)


def test_components_attach_and_values_change():
    world = cressim.World(cressim.SceneLayout(1))
    e = world.create_entity(env=0)
    assert not e.has(cressim.Transform)
    e.add(cressim.Transform(position=(1, 2, 3)))
    assert e.has(cressim.Transform)
    version = world.topology_version
    e.transform = cressim.Transform(position=(4, 5, 6))
    assert tuple(e.transform.position) == (4, 5, 6)
    assert world.topology_version == version  # a value change is not a topology change


def test_layout_rejects_zero_envs():
    with pytest.raises(ValueError, match="num_envs"):
        cressim.SceneLayout(0)
