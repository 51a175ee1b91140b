"""The twin's scene file moved below the twin, to cressim/twin_scene_file.py (the tasks read it
too, and they sit below the twin). These names stay importable here only until twin/arms.py,
twin/cart.py, cressim_ros, benchmarks/ and tests/twin/ import them from there; then delete this."""
from cressim.twin_scene_file import (
    CART_ARMS,
    DEFAULT_SCENE,
    DYNAMICS,
    ECM_HOME,
    ROBOTS,
    SCENE_DIR_ENV,
    SENSORS,
    CartArm,
    Scene,
    SceneError,
    find_scene,
    load_scene,
    parse_scene,
    rates_problem,
)

__all__ = ["CART_ARMS", "DEFAULT_SCENE", "DYNAMICS", "ECM_HOME", "ROBOTS", "SCENE_DIR_ENV", "SENSORS", "CartArm", "Scene",
           "SceneError", "find_scene", "load_scene", "parse_scene", "rates_problem"]
