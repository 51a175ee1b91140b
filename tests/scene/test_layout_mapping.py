import numpy as np
import pytest

import cressim


def test_mapping_groups_rows_by_env_in_creation_order(make_engine, small_world):
    engine = make_engine(small_world)
    engine.prepare()
    m = engine.mapping
    assert list(m["env_count"]) == [3, 3, 3, 3]
    assert list(m["env_offset"]) == [0, 3, 6, 9]
    assert list(m["env_index"]) == [0, 0, 0, 1, 1, 1, 2, 2, 2, 3, 3, 3]
    assert list(m["entity_id"][:3]) == [0, 4, 8]
    # entity_row inverts entity_id
    assert np.array_equal(m["entity_id"][m["entity_row"]], np.arange(12))


def test_env_isolation_of_mappings(make_engine):
    """Each env's rows hold only its own entities, whatever the others hold."""
    world = cressim.World(cressim.SceneLayout(3))
    counts = [2, 0, 5]
    for env, n in enumerate(counts):
        for _ in range(n):
            world.create_entity(env=env)
    engine = make_engine(world)
    engine.prepare()
    engine.upload_world()
    m = engine.mapping
    assert list(m["env_count"]) == counts
    for env in range(3):
        rows = slice(m["env_offset"][env], m["env_offset"][env] + m["env_count"][env])
        assert set(m["env_index"][rows]) <= {env}
    # the same mapping lives on the GPU for passes to read
    assert np.array_equal(engine.buffer("entity.env").read(), m["env_index"])
    assert np.array_equal(engine.buffer("env.entity_count").read(), np.array(counts, np.uint32))


def test_transforms_upload_in_row_order(make_engine, small_world):
    engine = make_engine(small_world)
    engine.prepare()
    engine.upload_world()
    pos = engine.buffer("transform.positions").read()
    m = engine.mapping
    assert pos.shape == (12, 4)
    assert np.array_equal(pos[:, 0], m["env_index"].astype(np.float32))  # x encodes the env
    assert np.array_equal(pos[:, 1], m["entity_id"].astype(np.float32))  # y encodes the entity


def test_topology_change_after_upload_asks_for_prepare(make_engine, small_world):
    engine = make_engine(small_world)
    engine.prepare()
    engine.upload_world()
    small_world.create_entity(env=1, name="late")
    with pytest.raises(cressim.TopologyError, match=r"created entity 12 'late' in env 1.*prepare\(\)"):
        engine.step_physics()
    with pytest.raises(cressim.TopologyError, match="prepare"):
        engine.end_frame()
    engine.prepare()
    engine.upload_world()
    engine.step_physics()
    engine.end_frame()
    assert engine.mapping["env_count"][1] == 4


def test_value_change_after_upload_needs_no_prepare(make_engine, small_world):
    engine = make_engine(small_world)
    engine.prepare()
    engine.upload_world()
    e = small_world.entity(5)
    e.transform = cressim.Transform(position=(9, 8, 7))
    engine.end_frame()
    row = engine.mapping["entity_row"][5]
    assert list(engine.buffer("transform.positions").read()[row, :3]) == [9, 8, 7]


def test_engine_used_out_of_order(make_engine, small_world):
    engine = make_engine(small_world)
    with pytest.raises(cressim.TopologyError, match="prepare"):
        engine.upload_world()
    with pytest.raises(cressim.TopologyError, match="upload_world"):
        engine.end_frame()
