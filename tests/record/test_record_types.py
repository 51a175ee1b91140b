"""Message types and CDR: crtk_msgs from the workspace's .msg files, dict/dataclass/rclpy inputs."""
import json
from pathlib import Path

import numpy as np
import pytest
from rosbags.typesys import get_types_from_msg

from cressim.record import types as T

REPO = Path(__file__).resolve().parents[2]
CRTK_MSG = REPO / "ros_ws" / "src" / "crtk_msgs" / "msg"
CRTK_SHARE = REPO / "ros_ws" / "install" / "share" / "crtk_msgs" / "msg"


def test_crtk_types_come_from_the_workspace_and_match_the_fallback_copy():
    assert T.crtk_msg_dir() == CRTK_MSG
    files = T.crtk_definitions()
    # the fallback holds the crtk types the twin publishes (what a bag of it can contain)
    assert set(T.CRTK_MSGS_FALLBACK) <= set(files)
    for name, text in T.CRTK_MSGS_FALLBACK.items():
        assert get_types_from_msg(files[name], name) == get_types_from_msg(text, name), name
    store = T.typestore()
    assert {"crtk_msgs/msg/OperatingState", "crtk_msgs/msg/StringStamped",
            "crtk_msgs/msg/CartesianState"} <= set(store.types)


@pytest.mark.parametrize("name", ["OperatingState", "StringStamped", "CartesianState"])
def test_crtk_type_hash_equals_the_ros_generated_one(name):
    """RIHS01 written into bags equals what rosidl computed when building crtk_msgs."""
    generated = CRTK_SHARE / f"{name}.json"
    if not generated.is_file():
        pytest.skip("crtk_msgs not built (ros_ws/build.sh)")
    expected = json.loads(generated.read_text())["type_hashes"][0]["hash_string"]
    assert T.message_definition(f"crtk_msgs/msg/{name}")[1] == expected


def test_dict_dataclass_roundtrip_and_defaults():
    msg = {"header": {"stamp": T.stamp(1_700_000_000_123_456_789), "frame_id": "PSM1_base"},
           "name": ["yaw", "pitch"], "position": [0.1, -0.2]}
    name, data = T.encode(msg, "sensor_msgs/JointState")
    assert name == "sensor_msgs/msg/JointState"
    back = T.decode(data, name)
    assert back.header.stamp.sec == 1_700_000_000 and back.header.stamp.nanosec == 123_456_789
    assert back.header.frame_id == "PSM1_base" and back.name == ["yaw", "pitch"]
    np.testing.assert_array_equal(back.position, [0.1, -0.2])
    assert back.velocity.dtype == np.float64 and len(back.velocity) == 0  # missing fields: empty/zero
    assert T.encode(back)[1] == data  # a dataclass serialises to the same bytes
    assert T.to_dict(back)["position"] == [0.1, -0.2]
    assert T.stamp_ns(back.header.stamp) == 1_700_000_000_123_456_789


def test_nested_and_fixed_size_types():
    tf = {"transforms": [{"header": {"frame_id": "PSM1_base"}, "child_frame_id": "PSM1",
                          "transform": {"translation": {"x": 1.0}, "rotation": {"w": 1.0}}}]}
    back = T.decode(T.encode(tf, "tf2_msgs/msg/TFMessage")[1], "tf2_msgs/msg/TFMessage")
    assert back.transforms[0].child_frame_id == "PSM1" and back.transforms[0].transform.rotation.w == 1.0
    jac = {"layout": {"dim": [{"label": "rows", "size": 6, "stride": 36}, {"label": "cols", "size": 6, "stride": 6}]},
           "data": np.arange(36.0)}
    back = T.decode(T.encode(jac, "std_msgs/msg/Float64MultiArray")[1], "std_msgs/msg/Float64MultiArray")
    assert [d.label for d in back.layout.dim] == ["rows", "cols"]
    np.testing.assert_array_equal(back.data, np.arange(36.0))
    twist = T.decode(T.encode({}, "geometry_msgs/msg/TwistStamped")[1], "geometry_msgs/msg/TwistStamped")
    assert twist.twist.linear.x == 0.0
    state = T.from_dict("crtk_msgs/msg/OperatingState", {"state": "ENABLED", "is_homed": 1})
    assert state.is_homed is True and state.STATE_FAULT == "FAULT"


def test_encode_refuses_what_it_cannot_type():
    with pytest.raises(ValueError):
        T.encode(b"\x00\x01\x00\x00")  # bytes need a type
    with pytest.raises(ValueError):
        T.encode({"position": [1.0]})  # a dict needs a type
    with pytest.raises(ValueError):
        T.encode({"bogus": 1}, "sensor_msgs/msg/JointState")
    with pytest.raises(KeyError):
        T.encode({}, "nope_msgs/msg/Nothing")
    js = T.from_dict("sensor_msgs/msg/JointState", {})
    with pytest.raises(ValueError):
        T.encode(js, "std_msgs/msg/String")


def test_rclpy_messages_serialise_to_the_same_cdr(rclpy_env):
    from builtin_interfaces.msg import Time
    from crtk_msgs.msg import OperatingState
    from sensor_msgs.msg import JointState

    js = JointState(name=["yaw", "pitch", "insertion"], position=[0.1, 0.2, 0.05], velocity=[1.0, 2.0, 3.0])
    js.header.stamp = Time(sec=12, nanosec=34)
    js.header.frame_id = "x"
    name, data = T.encode(js)
    assert name == "sensor_msgs/msg/JointState"
    ours = T.encode({"header": {"stamp": {"sec": 12, "nanosec": 34}, "frame_id": "x"}, "name": list(js.name),
                     "position": list(js.position), "velocity": list(js.velocity)}, name)[1]
    # byte for byte: rclpy's serialize_message pads (junk after the payload, uninitialised
    # alignment bytes); encode() normalises that to the exact CDR DDS sends
    assert data == ours
    back = T.decode(data, name)
    assert back.name == ["yaw", "pitch", "insertion"] and list(back.velocity) == [1.0, 2.0, 3.0]
    from rclpy.serialization import serialize_message

    padded = serialize_message(js)
    assert T.to_dict(T.decode(padded, name)) == T.to_dict(back)  # decode tolerates the padding
    st = OperatingState(state="ENABLED", is_homed=True)
    st.header.stamp = Time(sec=5)
    name, data = T.encode(st)
    assert name == "crtk_msgs/msg/OperatingState"
    back = T.decode(data, name)
    assert back.state == "ENABLED" and back.is_homed and not back.is_busy and back.header.stamp.sec == 5
