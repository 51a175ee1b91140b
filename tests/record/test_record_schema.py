"""The dataset schema: one table in schema.py, shown verbatim in bags/README.md."""
from pathlib import Path

import numpy as np

from cressim.record import schema, types

REPO = Path(__file__).resolve().parents[2]


def test_readme_shows_the_schema_table():
    readme = (REPO / "bags" / "README.md").read_text()
    begin, end = readme.index("<!-- schema:begin"), readme.index("<!-- schema:end -->")
    table = readme[readme.index("\n", begin) + 1:end]
    assert table.strip() == schema.schema_markdown().strip(), "regenerate it: cressim.record.schema.schema_markdown()"


def test_every_schema_type_is_known_and_names_are_unique():
    store = types.typestore()
    names = [t.name for t in schema.PSM_TOPICS]
    assert len(names) == len(set(names))
    for t in schema.PSM_TOPICS:
        assert t.msgtype in store.types, t
        assert t.role in ("state", "event", "command")
    assert schema.topics()["/PSM1/measured_js"] == "sensor_msgs/msg/JointState"
    assert schema.topics("PSM2")["/PSM2/jaw/servo_jp"] == "sensor_msgs/msg/JointState"
    assert schema.topics(roles=("event",))["/PSM1/operating_state"] == "crtk_msgs/msg/OperatingState"
    assert schema.TOPICS_BY_NAME["measured_cp"].frame_id("PSM2") == "PSM2_base"


def test_qos_follows_dvrk_md():
    by = schema.TOPICS_BY_NAME
    assert by["measured_js"].qos["depth"] == 100 and by["measured_js"].qos["durability"] == "volatile"
    assert by["operating_state"].qos["durability"] == "transient_local"
    assert by["servo_jp"].qos["depth"] == 1
    assert all(t.qos["reliability"] == "reliable" for t in schema.PSM_TOPICS)


def test_joint_names_and_the_numpy_fk_used_for_the_sample():
    assert schema.canonical_joint("outer_wrist_yaw") == "wrist_yaw"
    assert schema.canonical_joint("jaw") == "jaw"
    from cressim.record.synthetic import _forward_kinematics

    from cressim.robots.dvrk_dh import dh_forward_kinematics
    rng = np.random.default_rng(0)
    q = rng.uniform(-0.6, 0.6, (32, 6))
    q[:, 2] = rng.uniform(0.0, 0.24, 32)
    np.testing.assert_allclose(_forward_kinematics(q), dh_forward_kinematics(q), atol=1e-12)
    # the "real arm" (the DH table) and the twin's URDF chain agree
    from cressim.robots.kinematics import ArmKinematics
    from cressim.robots.psm import PSM

    import torch
    kin = ArmKinematics(PSM("psm_lnd.urdf", dtype=torch.float64), "cpu")
    np.testing.assert_allclose(_forward_kinematics(q), kin.forward(torch.as_tensor(q)).numpy(), atol=1e-9)
