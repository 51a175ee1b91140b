"""cressim.config, the one field reader: a bad value gives `file:line:column: field: reason`, the
place checked against the YAML text, for each of its readers (engine scene files, the twin's
sections, randomization files and Python configs; ROS parameter files: tests/twin/
test_params_file.py), and the error type's names are one class."""
import math
import textwrap

import pytest

from cressim import config
from cressim.config import Field, FieldError, parse


def at(text: str, line: int, token: str) -> str:
    """line:column (1-based) of the first `token` on 1-based `line` of `text`."""
    return f"{line}:{text.splitlines()[line - 1].index(token) + 1}"


def fails(text: str, read) -> FieldError:
    with pytest.raises(FieldError) as e:
        read(parse(text, "c.yaml"))
    return e.value


TEXT = textwrap.dedent("""\
    arm:
      base: {position: [0, 1, x], rotation: [0, 0, 0, 2]}
      lag: .inf
      count: 2.5
      mode: cout
    list: 3
    """)


@pytest.mark.parametrize("read, line, token, field, reason", [
    (lambda f: f.items()["arm"].items()["base"].items()["position"].vec(3, "finite"), 2, "x",
     "arm.base.position[2]", "expected a number, got 'x'"),
    (lambda f: f.items()["arm"].items()["base"].items()["rotation"].rotation(), 2, "[0, 0, 0, 2]",
     "arm.base.rotation", "quaternion x, y, z, w of norm 1 expected, norm is 2"),
    (lambda f: f.items()["arm"].items()["lag"].number(0, 1, "s"), 3, ".inf", "arm.lag", "must be finite, got inf"),
    (lambda f: f.items()["arm"].items()["count"].int(), 4, "2.5", "arm.count", "expected an integer, got 2.5"),
    (lambda f: f.items()["arm"].items()["mode"].choice(("coag", "cut")), 5, "cout", "arm.mode",
     "'cout' is not one of coag, cut (did you mean 'cut'?)"),
    (lambda f: f.items()["arm"].keys(("base", "lag", "count", "mod")), 5, "mode", "arm.mode",
     "unknown field 'mode'; expected one of: base, lag, count, mod (did you mean 'mod'?)"),
    (lambda f: f.items()["list"].list(), 6, "3", "list", "expected a list"),
    (lambda f: f.items()["arm"].items()["base"].bool(), 2, "{", "arm.base", "expected a single value"),
])
def test_each_accessor_names_file_line_column_field_and_reason(read, line, token, field, reason):
    error = fails(TEXT, read)
    assert str(error) == f"c.yaml:{at(TEXT, line, token)}: {field}: {reason}"
    assert (error.where, error.field, error.reason) == (f"c.yaml:{at(TEXT, line, token)}", field, reason)


def test_bounds_units_and_optional_values():
    f = parse("a: 1e-3\nb: -2\nc: ~\nd: 0\n", "c.yaml").items()
    assert f["a"].number(0, 1) == 1e-3  # YAML 1.1 reads 1e-3 as a string; it is a number here
    with pytest.raises(FieldError, match=r"^c.yaml:2:4: b: -2 Hz is outside \(0, 10\]$"):
        f["b"].number(0, 10, "Hz", open_low=True)
    with pytest.raises(FieldError, match=r"^c.yaml:2:4: b: -2 is outside \[1, 4\]$"):
        f["b"].int(1, 4)
    with pytest.raises(FieldError, match=r"^c.yaml:4:4: d: must be >= 1, got 0$"):
        f["d"].int(1)
    assert f["c"].optional(lambda g: g.vec(6)) is None and f["d"].optional(Field.int) == 0
    with pytest.raises(FieldError, match=r"^c.yaml:2:1: a: given twice$"):
        parse("a: 1\na: 2\n", "c.yaml").items()
    bad = "a: 1\n  b: 2\n"
    with pytest.raises(FieldError, match=rf"^c.yaml:{at(bad, 2, ':')}: not valid YAML: mapping values are not allowed here"):
        parse(bad, "c.yaml")


def test_python_values_name_their_origin():
    f = Field.of({"range": [0.5, math.nan], "every": True, "kind": "lineer"}, "Task(config=...)", "randomization[0]")
    with pytest.raises(FieldError, match=r"^Task\(config=...\): randomization\[0\].range\[1\]: must be finite, got nan$"):
        f.items()["range"].vec(2, "finite")
    with pytest.raises(FieldError, match=r"^Task\(config=...\): randomization\[0\].every: expected an integer, got True$"):
        f.items()["every"].int()
    with pytest.raises(FieldError, match=r"randomization\[0\].kind: 'lineer' is not one of linear, sector \(did you mean 'linear'\?\)"):
        f.items()["kind"].choice(("linear", "sector"))
    with pytest.raises(FieldError, match=r"randomization\[0\].rnage: unknown field 'rnage'"):
        Field.of({"rnage": 1}, "Task(config=...)", "randomization[0]").keys(("range",))


def test_one_error_type():
    from cressim.randomization import RandomizationError
    from cressim.scene_file import SceneFileError
    from cressim.twin_scene_file import SceneError

    assert SceneFileError is SceneError is RandomizationError is config.FieldError
    assert issubclass(FieldError, ValueError)


# --- each reader ---------------------------------------------------------------------------
ENGINE = textwrap.dedent("""\
    envs: 1
    entities:
      - name: ball
        rigid_body: {mass: 1}
        collider: {shapes: [{sphere: {radius: 0.05}}], restitution: lots}
    """)


def test_an_engine_scene_file(tmp_path):
    from cressim.scene_file import load_scene

    path = tmp_path / "scene.yaml"
    path.write_text(ENGINE)
    with pytest.raises(FieldError) as e:
        load_scene(path)
    assert str(e.value) == f"{path}:{at(ENGINE, 5, 'lots')}: entities[0].collider.restitution: expected a number, got 'lots'"


def test_the_twins_sections():
    from cressim.twin_scene_file import parse_scene

    text = "arm:\n  name: PSM1\n  cautery:\n    power: 500\nrates: {physics: 200, publish: 30}\n"
    with pytest.raises(FieldError) as e:
        parse_scene(text, "twin.yaml")
    assert str(e.value) == f"twin.yaml:{at(text, 4, '500')}: arm.cautery.power: 500 W is outside [0, 300]"
    with pytest.raises(FieldError) as e:  # a check across fields, at the field to change
        parse_scene(text.replace("500", "30"), "twin.yaml")
    assert str(e.value).startswith(f"twin.yaml:{at(text, 5, '200')}: rates.physics: 200 Hz is not an integer multiple")


RANDOMIZATION = textwrap.dedent("""\
    - param: mass
      entity: cart
      range: [0.5, 2.0]
    - param: friction
      entity: pole
      distribution: gausian
    """)


def test_a_randomization_file(tmp_path):
    from cressim.randomization import file_randomization

    path = tmp_path / "terms.yaml"
    path.write_text(RANDOMIZATION)
    with pytest.raises(FieldError) as e:
        file_randomization(path)
    assert str(e.value).startswith(f"{path}:{at(RANDOMIZATION, 6, 'gausian')}: [1].distribution: "
                                   "unknown distribution 'gausian'")


def test_a_python_randomization_config_names_its_origin():
    from cressim.randomization import load_terms

    with pytest.raises(FieldError) as e:
        load_terms([{"param": "mass", "entity": "cart", "range": [2.0, "big"]}], "CartPole(randomization=...)")
    assert str(e.value) == "CartPole(randomization=...): randomization[0].range[1]: expected a number, got 'big'"
