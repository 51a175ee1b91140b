"""The one field reader of configuration: engine scene files, the twin's sections, domain
randomization terms (from YAML or from Python) and the ROS node's parameter files.

A `Field` is a value and where it came from: a YAML node (its file, line and column) or a plain
Python value (an origin such as `Randomizer(terms=...)` instead of a file), and its dotted field
path. Its typed readers check the value and fail with one error type, whose message is
`file:line:column: dotted.field: reason`, which is what a user editing the file needs. YAML is
read with yaml.compose (not safe_load) so that every value keeps its node and so its place.
"""
from __future__ import annotations

import difflib
import math
from pathlib import Path

import yaml

_NULL = "tag:yaml.org,2002:null"


class FieldError(ValueError):
    """A configuration that cannot be used. Made by `at` (as the readers do), it keeps `where`
    (file:line:column, or the origin of a Python value), `field` (the dotted path; None: the
    whole file) and `reason`; checks made later (a term against a world) give a message alone."""

    where = field = reason = None

    @classmethod
    def at(cls, where: str, field: str | None, reason: str) -> FieldError:
        error = cls(f"{where}: {reason}" if field is None else f"{where}: {field or '(top)'}: {reason}")
        error.where, error.field, error.reason = where, field, reason
        return error


SceneFileError = FieldError  # the name scene-file callers catch (cressim.scene_file)


class Field:
    """A value of a configuration and where it is. `Field(node, file)` reads a YAML node;
    `Field.of(value, origin)` reads a Python value a user passed (dicts, lists, numbers)."""

    __slots__ = ("node", "value", "file", "path")

    def __init__(self, node: yaml.Node | None, file: str, path: str = "", *, value=None):
        self.node, self.value, self.file, self.path = node, value, file, path

    @classmethod
    def of(cls, value, origin: str, path: str = "") -> Field:
        return cls(None, origin, path, value=value)

    # --- where ---------------------------------------------------------------------------
    @property
    def where(self) -> str:
        """file:line:column of the node (1-based), or the origin of a Python value."""
        if self.node is None:
            return self.file
        mark = self.node.start_mark
        return f"{self.file}:{mark.line + 1}:{mark.column + 1}"

    def fail(self, reason: str) -> FieldError:
        return FieldError.at(self.where, self.path, reason)

    def _child(self, node, value, path: str) -> Field:
        return Field(node, self.file, path, value=value)

    def _join(self, key: str) -> str:
        return f"{self.path}.{key}" if self.path else key

    # --- structure -----------------------------------------------------------------------
    def is_map(self) -> bool:
        return isinstance(self.node, yaml.MappingNode) if self.node is not None else isinstance(self.value, dict)

    def is_list(self) -> bool:
        return isinstance(self.node, yaml.SequenceNode) if self.node is not None \
            else isinstance(self.value, (list, tuple))

    def is_null(self) -> bool:
        """An explicit null (YAML `null`, `~` or nothing; Python None): an optional value left out."""
        if self.node is None:
            return self.value is None
        return isinstance(self.node, yaml.ScalarNode) and self.node.tag == _NULL

    def optional(self, read):
        """None for a null, else `read(self)`: `f.optional(lambda f: f.vec(6))`."""
        return None if self.is_null() else read(self)

    def items(self) -> dict[str, Field]:
        """The mapping's fields by key; a key given twice is an error at its second place."""
        if not self.is_map():
            raise self.fail("expected a mapping (key: value)")
        out = {}
        if self.node is None:
            for k, v in self.value.items():
                out[str(k)] = self._child(None, v, self._join(str(k)))
            return out
        for k, v in self.node.value:
            key = str(k.value) if isinstance(k, yaml.ScalarNode) else yaml.serialize(k).strip()
            if key in out:
                raise self._child(k, None, self._join(key)).fail("given twice")
            out[key] = self._child(v, None, self._join(key))
        return out

    def keys(self, allowed) -> dict[str, Field]:
        """The mapping's fields, refusing a key not in `allowed` (a typo such as `num_env` would
        otherwise be silently ignored) with the closest allowed one."""
        allowed = tuple(sorted(allowed)) if isinstance(allowed, (set, frozenset)) else tuple(allowed)
        fields = self.items()
        keys = [k for k, _ in self.node.value] if self.node is not None else [None] * len(fields)
        for (k, f), key in zip(fields.items(), keys):
            if k not in allowed:
                at = f if key is None else self._child(key, None, f.path)  # the key's place: the typo
                raise at.fail(f"unknown field '{k}'; expected one of: {', '.join(allowed)}{_did_you_mean(k, allowed)}")
        return fields

    def list(self) -> list[Field]:
        if not self.is_list():
            got = "" if self.node is not None else f", got {self.value!r}"
            raise self.fail(f"expected a list{got}")
        if self.node is None:
            return [self._child(None, v, f"{self.path}[{i}]") for i, v in enumerate(self.value)]
        return [self._child(v, None, f"{self.path}[{i}]") for i, v in enumerate(self.node.value)]

    # --- scalars -------------------------------------------------------------------------
    def scalar(self):
        """The single value, typed as YAML types it (a quoted one stays a string)."""
        if self.node is None:
            if isinstance(self.value, (dict, list, tuple)):
                raise self.fail(f"expected a single value, got {self.value!r}")
            return self.value
        if not isinstance(self.node, yaml.ScalarNode):
            raise self.fail("expected a single value")
        return yaml.safe_load(self.node.value) if self.node.style is None else self.node.value

    def str(self) -> str:
        v = self.scalar()
        if not isinstance(v, str):
            raise self.fail(f"expected a name, got {v!r}")
        return v

    def choice(self, options) -> str:
        v = self.str()
        if v not in options:
            raise self.fail(f"{v!r} is not one of {', '.join(options)}{_did_you_mean(v, options)}")
        return v

    def float(self) -> float:
        """A number, infinities and NaN included (see `number` for a checked one)."""
        v = self.scalar()
        if isinstance(v, str) and self.node is not None and self.node.style is None:
            try:
                v = float(v)  # YAML 1.1 reads 1e-3 (no dot) as a string
            except ValueError:
                pass
        if isinstance(v, bool) or isinstance(v, str) or not (isinstance(v, (int, float)) or hasattr(v, "__float__")):
            raise self.fail(f"expected a number, got {v!r}")
        return float(v)

    def finite(self) -> float:
        v = self.float()
        if not math.isfinite(v):
            raise self.fail(f"must be finite, got {v}")
        return v

    def positive(self) -> float:
        v = self.float()
        if not v > 0 or not math.isfinite(v):
            raise self.fail(f"must be positive, got {v}")
        return v

    def number(self, low: float = -math.inf, high: float = math.inf, unit: str = "", *,
               open_low: bool = False) -> float:
        """A finite number in [low, high] ((low, high] with open_low); `unit` names it in the error."""
        v = self.finite()
        if not (low < v if open_low else low <= v) or not v <= high:
            raise self.fail(f"{v:g}{' ' + unit if unit else ''} is outside "
                            f"{'(' if open_low else '['}{low:g}, {high:g}]")
        return v

    def int(self, low: int | None = None, high: int | None = None) -> int:
        v = self.scalar()
        if isinstance(v, bool) or not (isinstance(v, int) or hasattr(v, "__index__")):
            raise self.fail(f"expected an integer, got {v!r}")
        v = int(v)
        if low is not None and high is not None and not low <= v <= high:
            raise self.fail(f"{v} is outside [{low}, {high}]")
        if low is not None and v < low:
            raise self.fail(f"must be >= {low}, got {v}")
        if high is not None and v > high:
            raise self.fail(f"must be <= {high}, got {v}")
        return v

    def bool(self) -> bool:
        v = self.scalar()
        if not isinstance(v, bool):
            raise self.fail(f"expected true or false, got {v!r}")
        return v

    def vec(self, n: int | tuple[int, ...], each: str = "float") -> tuple[float, ...]:
        """n numbers (or one of the sizes n lists), each read by the method `each` names
        (float, finite, positive), so an error names the number's own field."""
        sizes = (n,) if isinstance(n, int) else n
        if not self.is_list():
            raise self.fail(f"expected a list of {' or '.join(map(str, sizes))} numbers")
        items = self.list()
        if len(items) not in sizes:
            raise self.fail(f"expected {' or '.join(map(str, sizes))} numbers, got {len(items)}")
        return tuple(getattr(f, each)() for f in items)

    def ints(self, n: int, minimum: int | None = None) -> tuple[int, ...]:
        items = self.list()
        if len(items) != n:
            raise self.fail(f"expected {n} integers, got {len(items)}")
        return tuple(f.int(minimum) for f in items)

    def rotation(self) -> tuple[float, ...]:
        """A quaternion x, y, z, w of norm 1 (within 1e-3), returned normalized."""
        q = self.vec(4, "finite")
        norm = math.sqrt(sum(v * v for v in q))
        if abs(norm - 1.0) > 1e-3:
            raise self.fail(f"quaternion x, y, z, w of norm 1 expected, norm is {norm:.6g}")
        return tuple(v / norm for v in q)


def _did_you_mean(word: str, options) -> str:
    close = difflib.get_close_matches(word, [str(o) for o in options], n=1)
    return f" (did you mean '{close[0]}'?)" if close else ""


def parse(text: str, file: str) -> Field | None:
    """The YAML text as its top field, None when it holds nothing; YAML that does not parse
    raises FieldError at the place the parser stopped."""
    try:
        node = yaml.compose(text)
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f"{file}:{mark.line + 1}:{mark.column + 1}" if mark else file
        raise FieldError.at(where, None, f"not valid YAML: {getattr(e, 'problem', None) or e}") from None
    return None if node is None else Field(node, file)


def read_file(path) -> Field | None:
    """The YAML file at `path` as its top field (None when empty); a file that cannot be read or
    is no YAML raises FieldError naming it."""
    path = Path(path)
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as e:
        raise FieldError.at(str(path), None, f"cannot read the file: {e}") from None
    return parse(text, str(path))


def read_fields(path) -> Field:
    """As read_file, an empty file an error: for files that must say something."""
    root = read_file(path)
    if root is None:
        raise FieldError.at(f"{path}:1:1", None, "the file is empty")
    return root


__all__ = ["Field", "FieldError", "SceneFileError", "parse", "read_fields", "read_file"]
