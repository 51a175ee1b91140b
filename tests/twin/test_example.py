"""ros_ws/src/cressim_ros/examples/train_beside_twin.py runs: a learner on envs 1..N-1 inside the
twin's tick while a dVRK client drives env 0 over DDS (docs/twin.md, "Training beside the twin")."""
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.ros

EXAMPLE = Path(__file__).resolve().parents[2] / "ros_ws" / "src" / "cressim_ros" / "examples" / "train_beside_twin.py"


def test_train_beside_twin_example(ros_domain_id, tmp_path):
    run = subprocess.run([sys.executable, str(EXAMPLE), "--envs", "4", "--seconds", "3", "--episode-ticks", "25"],
                         capture_output=True, text=True, timeout=600, cwd=tmp_path)  # a safety limit
    out = run.stdout + run.stderr
    assert run.returncode == 0, out
    assert "episode   2:" in out and "learner: " in out, out
    assert "enabled True, homed True" in out and " 0 move_jp done" not in out, out
