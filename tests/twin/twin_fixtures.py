"""A twin shared by a test module (teardown registered with pytest's request)."""
from cressim_ros.twin_process import Twin


# Twins in tests render small images at 10 Hz (lavapipe renders on the test machine's CPU); a test's own
# camera_* parameters come later on the command line and win.
TEST_CAMERA = ("camera_width:=64", "camera_height:=48", "camera_rate:=10.0")


def module_twin(request, tmp_path_factory, domain, *params):
    twin = Twin(domain, tmp_path_factory.mktemp("twin") / "twin.log", *TEST_CAMERA, *params)
    request.addfinalizer(twin.stop)
    twin.startup_s = twin.wait_ready()
    return twin
