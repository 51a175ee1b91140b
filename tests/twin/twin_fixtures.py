"""A twin shared by a test module (teardown registered with pytest's request)."""
from cressim_ros.twin_process import Twin


# Twins in tests render small images at 2 Hz (lavapipe renders on the test machine's CPU); a test's own
# camera_* parameters come later on the command line and win.
TEST_CAMERA = ("camera_width:=64", "camera_height:=48", "camera_rate:=2.0")


# "Keeps publishing" is counted in ticks, never in Hz: on 2 loaded cores lavapipe, DDS and the
# client share the CPU and the rate is whatever the machine gives (rates are benchmarks' business).
def keeps_publishing(arm, ticks: int = 50, timeout: float = 120.0) -> bool:
    """measured_js keeps coming: `ticks` more messages (one per tick, however slowly the machine
    runs the twin; the timeout only catches a stalled twin)."""
    return arm.wait_measured(ticks, timeout=timeout)


def module_twin(request, tmp_path_factory, domain, *params):
    twin = Twin(domain, tmp_path_factory.mktemp("twin") / "twin.log", *TEST_CAMERA, *params)
    request.addfinalizer(twin.stop)
    twin.startup_s = twin.wait_ready()
    return twin
