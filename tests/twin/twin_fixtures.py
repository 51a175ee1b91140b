"""A twin shared by a test module (teardown registered with pytest's request)."""
from cressim_ros.twin_process import Twin


def module_twin(request, tmp_path_factory, domain, *params):
    twin = Twin(domain, tmp_path_factory.mktemp("twin") / "twin.log", *params)
    request.addfinalizer(twin.stop)
    twin.startup_s = twin.wait_ready()
    return twin
