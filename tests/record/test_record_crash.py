"""A recording survives a crash: SIGKILL the recorder after >= 3 s at 100 Hz; every message
handed to write() more than max_chunk_age (1 s) before the kill is in a complete chunk that
an independent reader can read, and recovery rebuilds a complete bag with all of them."""
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from mcap.reader import NonSeekingReader
from rosbags.rosbag2 import Reader as RosbagsReader

from cressim.record import BagFormatError, needs_recovery, read_messages, recover
from cressim.record import types as T
from cressim.record.recovery import is_complete
from cressim.record.writer import mcap_path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from crash_writer import expected  # noqa: E402

AGE = 1.0  # BagWriter's default max_chunk_age
RUN = 3.3  # seconds of recording before the kill


def _log(path):
    rows = []
    for line in Path(path).read_text().splitlines():
        parts = line.split()
        if len(parts) == 2:
            rows.append((int(parts[0]), int(parts[1])))
    return rows


@pytest.fixture(scope="module")
def crashed(tmp_path_factory):
    """(bag, log rows, kill time ns) of a recorder SIGKILLed mid-recording."""
    tmp = tmp_path_factory.mktemp("crash")
    bag, log = tmp / "crashed", tmp / "written.log"
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    child = subprocess.Popen([sys.executable, str(HERE / "crash_writer.py"), str(bag), str(log)], env=env)
    try:
        deadline = time.monotonic() + 60
        while not (log.exists() and _log(log)):
            assert child.poll() is None, "the recorder exited early"
            assert time.monotonic() < deadline, "the recorder did not start"
            time.sleep(0.01)
        first = _log(log)[0][1] / 1e9
        while time.monotonic() < first + RUN:
            assert child.poll() is None, "the recorder exited early"
            time.sleep(0.01)
        kill_ns = time.monotonic_ns()
        os.kill(child.pid, signal.SIGKILL)
    finally:
        if child.poll() is None:
            child.kill()
        child.wait(30)
    assert child.returncode == -signal.SIGKILL
    return bag, _log(log), kill_ns


def _must_survive(rows, kill_ns):
    return [i for i, t in rows if t < kill_ns - AGE * 1e9]


def test_the_kill_left_an_incomplete_bag(crashed):
    bag, rows, _ = crashed
    assert len(rows) >= 300  # >= 3 s at 100 Hz
    assert not (bag / "metadata.yaml").exists()
    assert not is_complete(mcap_path(bag)) and needs_recovery(bag)
    with pytest.raises(BagFormatError):
        list(read_messages(bag))


def test_closed_chunks_are_readable_without_recovery(crashed):
    """The mcap package's streaming reader, on the crashed file as it is: up to the torn end."""
    bag, rows, kill_ns = crashed
    seqs = []
    with open(mcap_path(bag), "rb") as f:
        try:
            for schema, channel, message in NonSeekingReader(f, validate_crcs=True).iter_messages(log_time_order=False):
                if channel.topic == "/PSM1/measured_js":
                    seqs.append(T.decode(message.data, schema.name).header.frame_id)
        except Exception:  # the torn last chunk (or its index)
            pass
    survivors = _must_survive(rows, kill_ns)
    assert len(survivors) >= 200
    assert set(f"seq{i}" for i in survivors) <= set(seqs)


def test_recovery_rebuilds_a_complete_bag_with_every_closed_chunk(crashed, independent_messages):
    bag, rows, kill_ns = crashed
    report = recover(bag)
    assert report.repaired and report.original and Path(report.original).exists()
    assert is_complete(mcap_path(bag)) and not needs_recovery(bag)
    survivors = _must_survive(rows, kill_ns)
    written = {i for i, _ in rows}

    # rosbags' reader: metadata.yaml + summary as rebuilt
    with RosbagsReader(bag) as reader:
        assert reader.message_count == report.messages
        js = [T.decode(raw, c.msgtype) for c, _, raw in reader.messages() if c.topic == "/PSM1/measured_js"]
    seqs = [int(m.header.frame_id[3:]) for m in js]
    assert seqs == list(range(len(seqs)))  # a gap-free prefix: a crash loses only the tail
    assert set(survivors) <= set(seqs) <= written | {max(written) + 1}
    # field by field, through the mcap reader with the bag's own schemas
    got = independent_messages(bag)
    by_seq = {m.header.frame_id: m for topic, _, _, m in got if topic == "/PSM1/measured_js"}
    for i in survivors:
        want = T.to_dict(T.from_dict("sensor_msgs/msg/JointState", expected(i)))
        assert T.to_dict(by_seq[f"seq{i}"]) == want
    # the channel registered mid-recording and the sparse topic came through too
    topics = {topic for topic, *_ in got}
    assert {"/PSM1/operating_state", "/PSM1/jaw/measured_js"} <= topics
    jaw = [int(m.header.frame_id[3:]) for topic, _, _, m in got if topic == "/PSM1/jaw/measured_js"]
    assert set(i for i in survivors if i >= 150) <= set(jaw)
    # recovering again is a no-op
    assert not recover(bag).repaired
