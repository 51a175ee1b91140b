"""A clean stop: the twin (a subprocess, as a user runs it), stopped with SIGINT (Ctrl-C) at once
after it is ready and while a client reads it, several times over, exits 0 and logs no error:
no tick failure, no traceback, nothing that could not be published (its shutdown summary
reaches /rosout like any other line) and the summary itself is there."""
import re

import pytest
from twin_fixtures import keeps_publishing

pytestmark = pytest.mark.ros

STOPS = 4
PROBLEM = re.compile(r"\[(ERROR|FATAL)\]|tick failed|Traceback|Failed to publish|exception", re.I)


@pytest.mark.parametrize("reading", [False, True], ids=["idle", "read"])
def test_sigint_stops_cleanly(reading, start_twin, ros_domain_id):
    from cressim_ros.dvrk_client import Arm, Ral

    for stop in range(STOPS):
        twin = start_twin(ros_domain_id)
        if reading:  # the tick publishes to a reader, and the stop comes in the middle of it
            ral = Ral("shutdown_client", ros_domain_id)
            arm = Arm(ral, "/PSM1")
            assert keeps_publishing(arm, ticks=20), twin.output()
        rc = twin.stop()
        if reading:
            ral.shutdown()
        output = twin.output()
        problems = [line for line in output.splitlines() if PROBLEM.search(line)]
        assert rc == 0 and not problems, f"stop {stop}: exit status {rc}, {problems[:5]}\n{output[-3000:]}"
        assert "tick time over the last" in output, output[-3000:]
