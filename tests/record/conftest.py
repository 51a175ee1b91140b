"""tests/record: recordings are real files read back by independent readers.

* ``independent_messages(bag)``: the mcap package's reader over the files metadata.yaml names,
  decoding with a typestore built only from the schemas stored in the bag (rosbags'
  EMPTY store + get_types_from_msg), nothing from cressim.
* rosbags' own rosbag2 Reader (metadata.yaml + its own MCAP parser) is used directly in tests.

rclpy-dependent tests run only when ``source ros_ws/env.sh`` made rclpy and crtk_msgs
importable; otherwise they are skipped with the reason.
"""
import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def _rclpy_problem():
    try:
        import rclpy  # noqa: F401
        from crtk_msgs.msg import OperatingState  # noqa: F401
    except ImportError as exc:
        return f"rclpy/crtk_msgs not importable ({exc}); run ros_ws/build.sh and source ros_ws/env.sh"
    return None


RCLPY_PROBLEM = _rclpy_problem()


@pytest.fixture
def rclpy_env():
    """Skips the test unless rclpy and crtk_msgs can be used in this process."""
    if RCLPY_PROBLEM is not None:
        pytest.skip(RCLPY_PROBLEM)


@pytest.fixture
def independent_messages():
    """independent_messages(bag, topics=None) (see _independent_messages)."""
    return _independent_messages


def _independent_messages(bag, topics=None):
    """[(topic, msgtype, log_time, decoded)] of a bag via the mcap package's reader and rosbags'
    typesys fed only with the bag's own schemas."""
    from mcap.reader import make_reader
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore
    from ruamel.yaml import YAML

    bag = Path(bag)
    meta = YAML(typ="safe").load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    out = []
    for rel in meta["relative_file_paths"]:
        with open(bag / rel, "rb") as f:
            reader = make_reader(f, validate_crcs=True)
            header_profile = next(iter(_header(bag / rel)))
            assert header_profile == "ros2"
            store = get_typestore(Stores.EMPTY)
            for schema in reader.get_summary().schemas.values():
                assert schema.encoding == "ros2msg"
                store.register(get_types_from_msg(schema.data.decode(), schema.name))
            for schema, channel, message in reader.iter_messages(topics=topics, log_time_order=True):
                assert channel.message_encoding == "cdr"
                out.append((channel.topic, schema.name, message.log_time,
                            store.deserialize_cdr(message.data, schema.name)))
    return out


def _header(path):
    from mcap.records import Header
    from mcap.stream_reader import StreamReader

    for record in StreamReader(str(path)).records:
        if isinstance(record, Header):
            yield record.profile
            return


@pytest.fixture
def ros_domain(monkeypatch):
    """A ROS_DOMAIN_ID of our own (localhost only) for tests that use DDS."""
    monkeypatch.setenv("ROS_DOMAIN_ID", str(100 + os.getpid() % 100))
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    return os.environ["ROS_DOMAIN_ID"]
