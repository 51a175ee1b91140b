"""The committed sample bag, its generator, and `cressim record` (synthetic, --info, --recover, ROS)."""
import importlib.util
import shutil
import threading
import time
from pathlib import Path

from rosbags.rosbag2 import Reader as RosbagsReader

from cressim.record import bag_info, read_messages
from cressim.record import types as T
from cressim.record.cli import main as record_cli
from cressim.record.schema import ARM_JOINTS, spec_for
from cressim.record.writer import mcap_path

REPO = Path(__file__).resolve().parents[2]
SAMPLE = REPO / "bags" / "psm1_sample"


def test_sample_is_small_complete_and_follows_the_schema(independent_messages):
    size = sum(p.stat().st_size for p in SAMPLE.iterdir())
    assert size < 1_000_000
    assert sorted(p.name for p in SAMPLE.iterdir()) == ["metadata.yaml", "psm1_sample_0.mcap"]
    with RosbagsReader(SAMPLE) as reader:
        assert reader.message_count == 3306
        for c in reader.connections:
            spec = spec_for(c.topic)
            assert spec is not None and spec.msgtype == c.msgtype, c.topic
    info = bag_info(SAMPLE)
    assert info["chunks"] > 1 and info["compression"] == ["zstd"]
    for topic, msgtype, _, msg in independent_messages(SAMPLE):
        spec = spec_for(topic)
        if hasattr(msg, "header") and spec.frame:
            assert msg.header.frame_id == spec.frame_id("PSM1"), topic
        if msgtype == "sensor_msgs/msg/JointState" and topic.endswith("_js"):
            assert msg.name == (["jaw"] if "/jaw/" in topic else list(ARM_JOINTS))
        if topic == "/tf":
            assert msg.transforms[0].header.frame_id == "PSM1_base" and msg.transforms[0].child_frame_id == "PSM1"
        if hasattr(msg, "header"):
            assert T.stamp_ns(msg.header.stamp) > 0  # stamps are never zero


def test_make_sample_regenerates_the_same_messages(tmp_path):
    spec = importlib.util.spec_from_file_location("make_sample", REPO / "bags" / "make_sample.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    out = module.make(tmp_path / "psm1_sample")
    fresh = [(m.topic, m.log_time, m.data) for m in read_messages(out)]
    committed = [(m.topic, m.log_time, m.data) for m in read_messages(SAMPLE)]
    assert fresh == committed


def test_cli_synthetic_info_and_recover(tmp_path, capsys):
    bag = tmp_path / "syn"
    assert record_cli(["record", "--synthetic", "1.0", "-o", str(bag)]) == 0
    assert "/PSM1/measured_js" in capsys.readouterr().out
    assert record_cli(["record", "--info", str(bag)]) == 0
    assert "sensor_msgs/msg/JointState" in capsys.readouterr().out
    # simulate a crash: cut the file inside its data and drop metadata.yaml
    crashed = tmp_path / "crashed"
    shutil.copytree(bag, crashed)
    (crashed / "syn_0.mcap").rename(mcap_path(crashed))
    (crashed / "metadata.yaml").unlink()
    data = mcap_path(crashed).read_bytes()
    mcap_path(crashed).write_bytes(data[: len(data) * 2 // 3])
    assert record_cli(["record", "--recover", str(crashed)]) == 0
    assert "recovered" in capsys.readouterr().out
    with RosbagsReader(crashed) as reader:
        assert 0 < reader.message_count < 3306
    assert record_cli(["record", "--recover", str(crashed)]) == 0
    assert "nothing to recover" in capsys.readouterr().out


def test_cli_records_over_ros(tmp_path, rclpy_env, ros_domain, capsys):
    import rclpy
    from crtk_msgs.msg import OperatingState
    from rclpy.qos import DurabilityPolicy, QoSProfile
    from sensor_msgs.msg import JointState

    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    node = rclpy.create_node("fake_arm", context=ctx)
    js_pub = node.create_publisher(JointState, "/PSM1/measured_js", QoSProfile(depth=100))
    st_pub = node.create_publisher(OperatingState, "/PSM1/operating_state",
                                   QoSProfile(depth=100, durability=DurabilityPolicy.TRANSIENT_LOCAL))
    st_pub.publish(OperatingState(state="ENABLED", is_homed=True))  # before the recorder exists
    stop = threading.Event()

    def publish():
        i = 0
        while not stop.is_set():
            js_pub.publish(JointState(name=list(ARM_JOINTS), position=[float(i)] * 6))
            i += 1
            time.sleep(0.01)
    thread = threading.Thread(target=publish, daemon=True)
    thread.start()
    bag = tmp_path / "ros"
    try:
        assert record_cli(["record", "-o", str(bag), "--duration", "2.0",
                           "--topics", "measured_js", "operating_state", "servo_jp"]) == 0
    finally:
        stop.set()
        thread.join(5)
        node.destroy_node()
        ctx.shutdown()
    with RosbagsReader(bag) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        js = [T.decode(raw, c.msgtype) for c, _, raw in reader.messages() if c.topic == "/PSM1/measured_js"]
    assert counts["/PSM1/operating_state"] == 1  # transient local: the latched state was recorded
    assert counts["/PSM1/measured_js"] > 50
    positions = [m.position[0] for m in js]
    assert positions == sorted(positions) and positions[-1] - positions[0] == len(positions) - 1  # none lost
    assert "/PSM1/servo_jp" in counts  # declared (no traffic)
