"""The package's layers, declared once here, and the test that holds the code to them: a module
imports only from its own layer and the layers below (at module level or inside a function, a
lazy import too), modules never import each other in a cycle, and `cressim` never imports
`cressim_ros`. docs/layers.md says what each layer holds; it lists them in this order.

The table lives with its test, not in the package: nothing at run time reads it, and a module of
the package that only a test imports would be dead weight with a layer of its own to declare."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

from .import_graph import GraphError, Import, cycles, imports, modules

REPO = Path(__file__).resolve().parents[2]
PACKAGES = {"cressim": REPO / "python" / "cressim", "cressim_ros": REPO / "ros_ws" / "src" / "cressim_ros" / "cressim_ros"}
COMPILED = {"cressim._core"}  # the pybind11 module: no Python source to read

# Bottom to top. A tier's layers are independent: none imports another of its tier. A module is
# in the layer of the longest prefix that names it (`cressim` alone is the package's facade).
LAYERS = (
    {"dvrk facts": ("cressim.robots.dvrk", "cressim.robots.dvrk_dh")},  # names and DH tables: numpy at most
    {"engine": ("cressim", "cressim._core", "cressim.compute", "cressim.io", "cressim.tendons", "cressim.suture",
                "cressim.tet_mesh_file", "cressim.sensors", "cressim.passes", "cressim.registration"),
     "record": ("cressim.record",),
     "config": ("cressim.config",)},
    {"randomization": ("cressim.randomization",)},
    {"scene": ("cressim.scene_file", "cressim.render_scene"),
     "robots": ("cressim.robots",)},
    {"twin scene file": ("cressim.twin_scene_file",)},
    {"envs": ("cressim.envs",)},
    {"learn": ("cressim.learn",),
     "twin": ("cressim.twin",)},
    {"datasets": ("cressim.datasets",),
     "demos": ("cressim.demos",)},
    {"command line": ("cressim.cli", "cressim.__main__")},
    {"ros": ("cressim_ros",)},
)

# Imports that break the rules today, each owned by the slice that removes it (and removes its
# line here: an allowance no longer needed fails the test too).
ALLOWED: dict[tuple[str, str], str] = {
}


def layer_of(module: str, layers=LAYERS) -> tuple[int, str]:
    """(tier, layer) of `module`: the longest prefix in the table that names it."""
    best = None
    for tier, group in enumerate(layers):
        for name, prefixes in group.items():
            for p in prefixes:
                if (module == p or module.startswith(p + ".")) and (best is None or len(p) > len(best[0])):
                    best = (p, tier, name)
    if best is None:
        raise LookupError(module)
    return best[1], best[2]


def problems(files: dict[str, Path], edges: list[Import], layers=LAYERS, allowed=ALLOWED) -> list[str]:
    """Every broken rule as `file:line: what`, and every allowance that no longer allows anything."""
    out, used, unplaced = [], set(), set()
    for module, f in sorted(files.items()):
        try:
            layer_of(module, layers)
        except LookupError:
            out.append(f"{f}:1: module {module} is in no layer: add it to LAYERS (and docs/layers.md)")
            unplaced.add(module)
    for e in edges:
        if e.source in unplaced or e.target in unplaced:
            continue
        (s_tier, s_layer), (t_tier, t_layer) = layer_of(e.source, layers), layer_of(e.target, layers)
        rule = None
        if e.source.split(".")[0] == "cressim" and e.target.split(".")[0] == "cressim_ros":
            rule = "cressim never imports cressim_ros (the ROS package wires ROS to cressim, not back)"
        elif t_tier > s_tier:
            rule = f"layer '{s_layer}' imports the higher layer '{t_layer}'"
        elif t_tier == s_tier and t_layer != s_layer:
            rule = f"layer '{s_layer}' imports '{t_layer}', independent of it (same tier)"
        if rule is None:
            continue
        if (e.source, e.target) in allowed:
            used.add((e.source, e.target))
            continue
        lazy = " (inside a function)" if e.in_function else ""
        out.append(f"{e.where}: {e.source} imports {e.target}{lazy}: {rule}")
    for cycle in cycles(edges):
        excused = [(e.source, e.target) for e in cycle if (e.source, e.target) in allowed]
        if excused:  # the allowance names the edge whose removal breaks the cycle
            used.update(excused)
            continue
        path = " -> ".join([cycle[0].source] + [e.target for e in cycle])
        steps = "; ".join(f"{e.where}{' (inside a function)' if e.in_function else ''}" for e in cycle)
        out.append(f"{cycle[0].where}: import cycle {path} (at {steps}); move the shared piece down")
    out += [f"ALLOWED: {s} -> {t} ({why}) is no longer needed: remove it" for (s, t), why in allowed.items()
            if (s, t) not in used]
    return out


def graph(packages: dict[str, Path] = PACKAGES, extra=COMPILED) -> tuple[dict[str, Path], list[Import]]:
    files = {}
    for d in packages.values():
        files.update(modules(d))
    return files, imports(files, tuple(packages), set(extra))


def test_every_module_in_a_layer_no_import_of_a_higher_layer_and_no_cycle():
    found = problems(*graph())
    assert not found, "\n".join(found)


def test_docs_list_the_layers_in_order():
    text = (REPO / "docs" / "layers.md").read_text()
    listed = re.findall(r"^\| \*\*(.+?)\*\* \| (\d+) \|", text, re.M)
    declared = [(name, str(tier)) for tier, group in enumerate(LAYERS) for name in group]
    assert listed == declared, "docs/layers.md's table: (layer, tier) rows, bottom first, as LAYERS"


# --- the checker itself, on planted trees ------------------------------------------------------
PLANTED = (
    {"low": ("pkg", "pkg.low")},
    {"mid": ("pkg.mid",), "side": ("pkg.side",)},
    {"high": ("pkg.high",)},
)


def _tree(root: Path, files: dict[str, str]) -> dict[str, Path]:
    for name, text in files.items():
        path = root / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return {"pkg": root / "pkg"}


def _problems(tmp_path, files: dict[str, str], allowed=None) -> list[str]:
    base = {"pkg/__init__.py": "", "pkg/low.py": "", "pkg/mid/__init__.py": "", "pkg/side.py": "", "pkg/high.py": ""}
    return problems(*graph(_tree(tmp_path, {**base, **files}), ()), PLANTED, allowed or {})


def test_a_clean_planted_tree_passes(tmp_path):
    assert _problems(tmp_path, {"pkg/high.py": "from pkg.mid import x\nimport pkg.low\nfrom . import side\n",
                                "pkg/mid/__init__.py": "from ..low import y\n"}) == []


def test_a_lazy_import_of_a_higher_layer_is_named_with_file_line_and_both_layers(tmp_path):
    found = _problems(tmp_path, {"pkg/mid/tool.py": "import os\n\n\ndef f():\n    from pkg.high import g\n"})
    assert found == [f"{tmp_path / 'pkg/mid/tool.py'}:5: pkg.mid.tool imports pkg.high (inside a function): "
                     "layer 'mid' imports the higher layer 'high'"]


def test_an_import_between_independent_layers_fails(tmp_path):
    found = _problems(tmp_path, {"pkg/side.py": "from .mid import thing\n"})
    assert len(found) == 1 and "layer 'side' imports 'mid', independent of it (same tier)" in found[0]


def test_a_cycle_within_one_layer_fails_naming_each_step(tmp_path):
    found = _problems(tmp_path, {"pkg/mid/a.py": "from . import b\n",
                                 "pkg/mid/b.py": "def f():\n    from pkg.mid.a import x\n"})
    assert len(found) == 1
    assert "import cycle pkg.mid.a -> pkg.mid.b -> pkg.mid.a" in found[0]
    assert f"{tmp_path / 'pkg/mid/b.py'}:2 (inside a function)" in found[0]


def test_cressim_importing_cressim_ros_fails(tmp_path):
    _tree(tmp_path, {"cressim/__init__.py": "", "cressim/low.py": "import cressim_ros.node\n",
                     "cressim_ros/__init__.py": "", "cressim_ros/node.py": "import cressim.low\n"})
    layers = ({"low": ("cressim",)}, {"ros": ("cressim_ros",)})
    found = problems(*graph({"cressim": tmp_path / "cressim", "cressim_ros": tmp_path / "cressim_ros"}, ()), layers, {})
    assert any("cressim.low imports cressim_ros.node: cressim never imports cressim_ros" in p for p in found)
    assert any("import cycle" in p for p in found)


def test_an_allowance_hides_its_import_and_fails_once_unused(tmp_path):
    files = {"pkg/low.py": "from pkg import high\n"}
    assert _problems(tmp_path, files, {("pkg.low", "pkg.high"): "planted"}) == []
    assert _problems(tmp_path, {}, {("pkg.low", "pkg.high"): "planted"}) == [
        "ALLOWED: pkg.low -> pkg.high (planted) is no longer needed: remove it"]


def test_a_module_in_no_layer_is_named(tmp_path):
    files = {"pkg/__init__.py": "", "pkg/low.py": "", "pkg/stray.py": "from . import low\n"}
    found = problems(*graph(_tree(tmp_path, files), ()), ({"low": ("pkg", "pkg.low")},), {})
    assert found == []
    found = problems(*graph(_tree(tmp_path, files), ()), ({"low": ("pkg.low",)},), {})
    assert found == [f"{tmp_path / 'pkg/__init__.py'}:1: module pkg is in no layer: add it to LAYERS (and docs/layers.md)",
                     f"{tmp_path / 'pkg/stray.py'}:1: module pkg.stray is in no layer: add it to LAYERS (and docs/layers.md)"]


def test_an_import_of_no_module_is_an_error_naming_file_line(tmp_path):
    with pytest.raises(GraphError, match=r"pkg/high.py:2: imports pkg.nothing, which is no module here"):
        _problems(tmp_path, {"pkg/high.py": "import os\nimport pkg.nothing\n"})
