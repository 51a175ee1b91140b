"""BagWriter: rosbag2 layout, round trip through independent readers, chunk bounds, queue policy."""
import threading
import time

import numpy as np
import pytest
from mcap.reader import make_reader
from rosbags.rosbag2 import Reader as RosbagsReader
from ruamel.yaml import YAML

from cressim.record import BagCore, BagFormatError, BagWriter, RecorderError, bag_info, read_messages
from cressim.record import types as T
from cressim.record.recovery import is_complete, scan_records
from cressim.record.schema import ARM_JOINTS
from cressim.record.writer import MESSAGE_RECORD_OVERHEAD, mcap_path

JS = "sensor_msgs/msg/JointState"


def joint_state(i, names=ARM_JOINTS):
    return {"header": {"stamp": T.stamp(1_700_000_000_000_000_000 + i * 10_000_000), "frame_id": f"seq{i}"},
            "name": list(names), "position": [i + 0.001 * j for j in range(len(names))],
            "velocity": [0.5 * i] * len(names), "effort": [-1.0 * i] * len(names)}


def sample_messages(n=50):
    """[(topic, msgtype, log_time, dict)] over several types, some topics sparse."""
    out = []
    t0 = 1_700_000_000_000_000_000
    for i in range(n):
        t = t0 + i * 10_000_000
        out.append(("/PSM1/measured_js", JS, t, joint_state(i)))
        out.append(("/PSM1/jaw/measured_js", JS, t + 1, joint_state(i, ["jaw"])))
        out.append(("/PSM1/measured_cp", "geometry_msgs/msg/PoseStamped", t + 2,
                    {"header": {"stamp": T.stamp(t), "frame_id": "PSM1_base"},
                     "pose": {"position": {"x": 0.01 * i, "y": -0.02, "z": -0.1},
                              "orientation": {"x": 0.0, "y": 0.0, "z": np.sin(i / 10), "w": np.cos(i / 10)}}}))
        if i % 10 == 0:
            out.append(("/PSM1/operating_state", "crtk_msgs/msg/OperatingState", t + 3,
                        {"header": {"stamp": T.stamp(t)}, "state": "ENABLED", "is_homed": i > 0, "is_busy": i == 20}))
            out.append(("/PSM1/body/jacobian", "std_msgs/msg/Float64MultiArray", t + 4,
                        {"layout": {"dim": [{"label": "rows", "size": 6, "stride": 36},
                                            {"label": "cols", "size": 6, "stride": 6}]},
                         "data": np.arange(36.0) * i}))
    return out


def assert_same(decoded, expected):
    """Field-by-field equality of a decoded dataclass with the dict it was written from."""
    got = T.to_dict(decoded)
    full = T.to_dict(T.from_dict(decoded.__msgtype__, expected))  # the dict with zero defaults filled in
    assert got == full


def test_roundtrip_through_mcap_and_rosbags_readers(tmp_path, independent_messages):
    msgs = sample_messages()
    bag = tmp_path / "run"
    with BagWriter(bag) as w:
        for topic, msgtype, t, msg in msgs:
            w.write(topic, msg, msgtype=msgtype, log_time=t)
    assert sorted(p.name for p in bag.iterdir()) == ["metadata.yaml", "run_0.mcap"]
    # 1. the mcap package's reader, types from the bag's schemas only
    got = independent_messages(bag)
    assert len(got) == len(msgs)
    for (topic, msgtype, t, msg), (gtopic, gtype, gt, decoded) in zip(sorted(msgs, key=lambda m: m[2]), got):
        assert (gtopic, gtype, gt) == (topic, msgtype, t)
        assert_same(decoded, msg)
    # 2. rosbags' rosbag2 reader: metadata.yaml, QoS, counts, its own MCAP parser
    with RosbagsReader(bag) as reader:
        assert reader.message_count == len(msgs)
        conns = {c.topic: c for c in reader.connections}
        assert conns["/PSM1/measured_js"].msgtype == JS and conns["/PSM1/measured_js"].msgcount == 50
        assert conns["/PSM1/operating_state"].msgcount == 5
        assert conns["/PSM1/operating_state"].ext.offered_qos_profiles[0].durability.name == "TRANSIENT_LOCAL"
        assert conns["/PSM1/measured_js"].ext.offered_qos_profiles[0].depth == 100
        assert conns["/PSM1/measured_js"].digest == T.message_definition(JS)[1]
        by_time = {(m[0], m[2]): m[3] for m in msgs}
        n = 0
        for conn, t, raw in reader.messages():
            assert_same(T.decode(raw, conn.msgtype), by_time[(conn.topic, t)])
            n += 1
        assert n == len(msgs)
    # 3. metadata.yaml as rosbag2 (Jazzy) writes it
    meta = YAML(typ="safe").load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert meta["version"] == 9 and meta["storage_identifier"] == "mcap"
    assert meta["relative_file_paths"] == ["run_0.mcap"] and meta["message_count"] == len(msgs)
    assert meta["starting_time"]["nanoseconds_since_epoch"] == min(m[2] for m in msgs)
    assert meta["duration"]["nanoseconds"] == max(m[2] for m in msgs) - min(m[2] for m in msgs)
    # 4. our reader agrees
    ours = list(read_messages(bag, "/PSM1/body/jacobian", decode=True))
    assert len(ours) == 5 and np.array_equal(ours[2][1].data, np.arange(36.0) * 20)
    info = bag_info(bag)
    assert info["message_count"] == len(msgs) and info["compression"] == ["zstd"]


def test_chunks_are_closed_at_the_size_bound(tmp_path):
    bag = tmp_path / "sized"
    chunk_size = 4096
    with BagWriter(bag, chunk_size=chunk_size) as w:
        for i in range(400):
            w.write("/PSM1/measured_js", joint_state(i), msgtype=JS)
    with open(mcap_path(bag), "rb") as f:
        summary = make_reader(f).get_summary()
    chunks = summary.chunk_indexes
    assert len(chunks) > 10
    largest = max(len(T.encode(joint_state(i), JS)[1]) for i in (0, 399)) + MESSAGE_RECORD_OVERHEAD
    schema_and_channel = 2048  # the first chunk also holds the schema and channel records
    for c in chunks:
        assert c.compression == "zstd"
        assert c.uncompressed_size <= chunk_size + largest + schema_and_channel
    assert sum(summary.statistics.channel_message_counts.values()) == 400


def test_chunks_are_closed_at_the_age_bound_deterministically(tmp_path):
    """BagCore with explicit hand-over times: the open chunk is due 0.9 x max_chunk_age after
    its oldest message, regardless of how many came later."""
    core = BagCore(tmp_path / "aged", max_chunk_age=1.0)
    data = T.encode(joint_state(0), JS)[1]
    assert core.deadline() is None and not core.due(100.0)
    core.write("/PSM1/measured_js", JS, data, 1, handed_at=100.0)
    for k in range(1, 9):
        core.write("/PSM1/measured_js", JS, data, 1 + k, handed_at=100.0 + 0.1 * k)
        assert not core.due(100.0 + 0.1 * k)
    assert core.deadline() == pytest.approx(100.9)
    assert core.due(100.9)
    core.close_chunk()
    assert core.chunks == 1 and core.deadline() is None
    # everything so far is on disk in a complete chunk, although the file is still open
    kinds = [k for k, _ in scan_records(core.path)]
    assert kinds.count("message") == 9 and kinds.count("chunk") == 1
    core.close()
    assert is_complete(core.path)


def test_flush_makes_everything_readable_while_recording(tmp_path):
    bag = tmp_path / "open"
    w = BagWriter(bag)
    for i in range(30):
        w.write("/PSM1/measured_js", joint_state(i), msgtype=JS)
    assert w.flush(timeout=10)
    seen = [r.data for k, r in scan_records(mcap_path(bag)) if k == "message"]
    assert [T.decode(d, JS).header.frame_id for d in seen] == [f"seq{i}" for i in range(30)]
    assert not is_complete(mcap_path(bag))  # no summary until close
    with pytest.raises(BagFormatError):
        list(read_messages(bag))
    w.close()
    assert is_complete(mcap_path(bag))


def test_age_bound_closes_chunks_without_flush(tmp_path):
    """With a short max_chunk_age the writer thread closes chunks on its own (no flush/close)."""
    bag = tmp_path / "age"
    w = BagWriter(bag, max_chunk_age=0.2)
    for i in range(10):
        w.write("/PSM1/measured_js", joint_state(i), msgtype=JS)
    deadline = time.monotonic() + 10.0
    while time.monotonic() < deadline:
        if sum(k == "message" for k, _ in scan_records(mcap_path(bag))) == 10:
            break
        time.sleep(0.05)
    assert sum(k == "message" for k, _ in scan_records(mcap_path(bag))) == 10
    assert w.stats["chunks"] >= 1
    w.close()


class _Gate:
    """Stalls the writer thread inside BagCore.write, as a slow disk would."""

    def __init__(self, writer):
        self.release = threading.Event()
        self.entered = threading.Event()
        core = writer._core
        original = core.write

        def slow_write(*args, **kwargs):
            self.entered.set()
            self.release.wait()
            return original(*args, **kwargs)
        core.write = slow_write


def test_full_queue_drops_oldest_and_counts_and_write_never_waits_for_disk(tmp_path):
    bag = tmp_path / "drop"
    w = BagWriter(bag, max_queue=10)
    gate = _Gate(w)
    w.write("/PSM1/measured_js", joint_state(0), msgtype=JS)
    assert gate.entered.wait(10)  # the writer thread holds message 0 and is stuck "on disk"
    # these all return although the disk does not move: write never waits for it
    for i in range(1, 26):
        w.write("/PSM1/measured_js", joint_state(i), msgtype=JS)
    stats = w.stats
    assert stats["queued"] == 10 and stats["dropped"] == 15 and stats["accepted"] == 26
    assert stats["dropped_by_topic"] == {"/PSM1/measured_js": 15} and stats["on_full"] == "drop_oldest"
    gate.release.set()
    w.close()
    kept = [m.decode().header.frame_id for m in read_messages(bag)]
    assert kept == ["seq0"] + [f"seq{i}" for i in range(16, 26)]  # the 15 oldest queued were dropped


def test_full_queue_blocks_when_asked(tmp_path):
    bag = tmp_path / "block"
    w = BagWriter(bag, max_queue=5, on_full="block")
    gate = _Gate(w)
    w.write("/PSM1/measured_js", joint_state(0), msgtype=JS)
    assert gate.entered.wait(10)
    for i in range(1, 6):
        w.write("/PSM1/measured_js", joint_state(i), msgtype=JS)  # fills the queue
    writer = threading.Thread(target=w.write, args=("/PSM1/measured_js", joint_state(6)), kwargs={"msgtype": JS})
    writer.start()
    writer.join(0.3)
    assert writer.is_alive()  # waiting for room
    gate.release.set()
    writer.join(10)
    assert not writer.is_alive()
    w.close()
    assert [m.decode().header.frame_id for m in read_messages(bag)] == [f"seq{i}" for i in range(7)]
    assert w.stats["dropped"] == 0


def test_errors_are_reported_not_swallowed(tmp_path):
    w = BagWriter(tmp_path / "err")
    w.write("/PSM1/measured_js", joint_state(0), msgtype=JS)
    with pytest.raises(ValueError):  # one topic, one type
        w.write("/PSM1/measured_js", {"data": "x"}, msgtype="std_msgs/msg/String")
    with pytest.raises(KeyError):
        w.write("/x", {}, msgtype="nope_msgs/msg/Nothing")
    with pytest.raises(ValueError):
        BagWriter(tmp_path / "bad", on_full="drop_newest")
    w.close()
    with pytest.raises(RecorderError):
        w.write("/PSM1/measured_js", joint_state(1), msgtype=JS)
    with pytest.raises(FileExistsError):
        BagWriter(tmp_path / "err")  # never overwrites a bag

    broken = BagWriter(tmp_path / "disk_full")

    def fail(*args, **kwargs):
        raise OSError(28, "No space left on device")
    broken._core.write = fail
    broken.write("/PSM1/measured_js", joint_state(0), msgtype=JS)
    with pytest.raises(RecorderError):
        broken.flush(timeout=10)
    with pytest.raises(RecorderError):
        broken.write("/PSM1/measured_js", joint_state(1), msgtype=JS)
    with pytest.raises(RecorderError):
        broken.close()


def test_rclpy_messages_are_recorded(tmp_path, rclpy_env, independent_messages):
    from crtk_msgs.msg import OperatingState
    from sensor_msgs.msg import JointState

    bag = tmp_path / "rclpy"
    with BagWriter(bag) as w:
        for i in range(20):
            js = JointState(name=list(ARM_JOINTS), position=[float(i)] * 6)
            js.header.stamp.sec = 100 + i
            w.write("/PSM1/measured_js", js)
        w.write("/PSM1/operating_state", OperatingState(state="ENABLED", is_homed=True))
    rows = [(topic, msg) for topic, _, _, msg in independent_messages(bag)]  # strict CDR parser
    js = [m for t, m in rows if t == "/PSM1/measured_js"]
    assert [m.header.stamp.sec for m in js] == list(range(100, 120))
    assert list(js[7].position) == [7.0] * 6 and js[7].name == list(ARM_JOINTS)
    (state,) = [m for t, m in rows if t == "/PSM1/operating_state"]
    assert state.state == "ENABLED" and state.is_homed
