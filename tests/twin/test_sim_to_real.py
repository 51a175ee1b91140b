"""The sim-to-real loop (ros_ws/src/cressim_ros/examples/sim_to_real.py): a policy trained in
batch on TissueRetract with the CRTK observation (examples/policies/tissue_retract_crtk.pt, PPO on
an H200: benchmarks/README.md) drives the twin's PSM through the dVRK's own Python client
(`dvrk.psm` on `crtk.ral`), over CRTK topics only, in a process of its own: it must grasp the
flap's free edge and lift it 20 mm, and the tool must then carry the tissue's pull
(spatial/measured_cf), which it does not in the air."""
import re
import subprocess
import sys
from pathlib import Path

import pytest
from twin_fixtures import script_env

pytestmark = pytest.mark.ros

EXAMPLES = Path(__file__).resolve().parents[2] / "ros_ws" / "src" / "cressim_ros" / "examples"
SAFETY_LIMIT = 900.0  # s: only catches a hang (the run takes about 20 s here)


def test_a_batch_trained_policy_retracts_the_flap_in_the_twin(clients, ros_domain_id, tmp_path):
    run = subprocess.run([sys.executable, str(EXAMPLES / "sim_to_real.py"), "--twin",
                          "--policy", str(EXAMPLES / "policies" / "tissue_retract_crtk.pt")],
                         env=script_env(clients, ros_domain_id), cwd=tmp_path, capture_output=True, text=True,
                         timeout=SAFETY_LIMIT)
    out = run.stdout + run.stderr
    assert run.returncode == 0, out + (tmp_path / "sim_to_real_twin.log").read_text()
    found = re.search(r"success after (\d+) steps: the jaws last closed at step (\d+), the tool rose ([0-9.]+) mm "
                      r"since, force on the tool \[([-0-9., e]+)\] N", out)
    assert found, out
    steps, closed_at, lift = int(found[1]), int(found[2]), float(found[3])
    force = [float(v) for v in found[4].split(",")]
    assert closed_at < steps <= 180 and lift >= 20.0
    assert sum(f * f for f in force) ** 0.5 > 0.05, f"the tool holds nothing: {force} N\n{out}"
