"""A twin shared by a test module (teardown registered with pytest's request)."""
from cressim_ros.twin_process import Twin


# Twins in tests render small images at 2 Hz (lavapipe renders on the test machine's CPU); a test's own
# camera_* parameters come later on the command line and win.
TEST_CAMERA = ("camera_width:=64", "camera_height:=48", "camera_rate:=2.0")


# "Keeps publishing at its rate" is checked against the rate the same twin reached before the
# test's commands, on the same machine, not against a wall-clock number: on 2 loaded cores
# lavapipe, DDS and the client share the CPU and the absolute rate varies (the brief: no test
# asserts a timing).
KEEP_RATE = 0.7


def baseline_rate(arm, window: float = 2.0) -> float:
    """measured_js rate over `window` s of quiet publishing (after waiting that long)."""
    import time

    time.sleep(window)
    rate = arm.measured_js_rate(window)
    assert rate > 0, "the twin does not publish measured_js"
    return rate


def module_twin(request, tmp_path_factory, domain, *params):
    twin = Twin(domain, tmp_path_factory.mktemp("twin") / "twin.log", *TEST_CAMERA, *params)
    request.addfinalizer(twin.stop)
    twin.startup_s = twin.wait_ready()
    return twin
