"""Let the robot tests import `cressim.robots` where the compiled engine is not built.

`cressim/__init__.py` imports the compiled `cressim._core`; the robot models need only torch,
numpy and yourdfpy. Where the engine is built (the project's venv) this
file does nothing. Where it is not (a robots-only venv), the package is registered without
running its `__init__`, so `import cressim.robots` still finds python/cressim/robots.
"""
import importlib.machinery
import importlib.util
import sys
from pathlib import Path

PACKAGE_DIR = Path(__file__).resolve().parents[2] / "python" / "cressim"

try:
    import cressim  # noqa: F401
except ImportError as error:
    if error.name == "cressim":  # not installed and not on the path: use the source tree
        sys.path.insert(0, str(PACKAGE_DIR.parent))
    try:
        import cressim  # noqa: F401,F811
    except ImportError:  # the compiled engine is missing: a bare package, robots only
        spec = importlib.machinery.ModuleSpec("cressim", None, is_package=True)
        spec.submodule_search_locations = [str(PACKAGE_DIR)]
        sys.modules["cressim"] = importlib.util.module_from_spec(spec)
