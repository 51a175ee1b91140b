"""The sim-to-real loop end to end: `cressim replay` drives a running twin from the sample bag's
commands over DDS, records the twin's response and reports tracking error per joint."""
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from cressim.record.reader import bag_info

REPO = Path(__file__).resolve().parents[2]


@pytest.mark.ros
def test_replay_of_the_sample_bag_against_the_twin(ros_domain_id, start_twin, tmp_path):
    start_twin(ros_domain_id)
    env = dict(os.environ, ROS_DOMAIN_ID=str(ros_domain_id), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    report = tmp_path / "report.json"
    response = tmp_path / "response"
    run = subprocess.run([sys.executable, "-m", "cressim", "replay", str(REPO / "bags" / "psm1_sample"),
                          "--enable", "--out", str(response), "--json", str(report),
                          "--clock", "sim", "--wait", "120"],  # simulated time: however busy the machine
                         env=env, capture_output=True, text=True, timeout=600)  # a safety limit
    assert run.returncode == 0, run.stdout + run.stderr
    errors = json.loads(report.read_text())["errors"]
    for table in errors.values():  # versus the commands, and versus the bag's own measured_js
        assert set(table) >= {"yaw", "pitch", "insertion", "roll", "wrist_pitch", "wrist_yaw"}
        for joint, e in table.items():
            assert e["n"] > 100 and e["rms"] < 0.05, (joint, e)  # tracks the recorded session
            assert abs(e["final"]) < 0.05, (joint, e)  # and ends near where it should
    # the twin's response was recorded beside, as a readable bag
    topics = bag_info(response)["topics"]
    names = [t["name"] if isinstance(t, dict) else t for t in topics]
    assert any("measured_js" in str(n) for n in names)
