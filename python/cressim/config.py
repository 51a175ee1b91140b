"""The field reader of YAML files (scene files, randomization terms): each value keeps its node, so
an error names file:line and the field's dotted path. Below both the scene-file loader and the
randomization terms, which read fields alike and each read the other's files."""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import yaml


class SceneFileError(ValueError):
    """A scene file (or a file of randomization terms) that cannot be loaded; the message starts
    with file:line: field. Named for the scene files, which most callers catch it from."""


@dataclass
class Field:
    """A YAML node and where it is: its file, line, and dotted field path."""

    node: yaml.Node
    file: str
    path: str

    def fail(self, message: str) -> SceneFileError:
        return SceneFileError(f"{self.where}: {self.path or '(top)'}: {message}")

    @property
    def where(self) -> str:
        """file:line of the node."""
        return f"{self.file}:{self.node.start_mark.line + 1}"

    # --- structure -------------------------------------------------------------------------
    def is_map(self) -> bool:
        return isinstance(self.node, yaml.MappingNode)

    def items(self) -> dict[str, Field]:
        if not self.is_map():
            raise self.fail("expected a mapping (key: value)")
        out = {}
        for k, v in self.node.value:
            key = str(k.value)
            if key in out:
                raise Field(k, self.file, self._join(key)).fail("given twice")
            out[key] = Field(v, self.file, self._join(key))
        return out

    def list(self) -> list[Field]:
        if not isinstance(self.node, yaml.SequenceNode):
            raise self.fail("expected a list")
        return [Field(v, self.file, f"{self.path}[{i}]") for i, v in enumerate(self.node.value)]

    def keys(self, allowed: tuple[str, ...]) -> dict[str, Field]:
        """The mapping's fields, refusing keys not in `allowed`."""
        fields = self.items()
        for k, f in fields.items():
            if k not in allowed:
                raise f.fail(f"unknown field '{k}'; expected one of: {', '.join(allowed)}")
        return fields

    def _join(self, key: str) -> str:
        return f"{self.path}.{key}" if self.path else key

    # --- scalars ---------------------------------------------------------------------------
    def _scalar(self):
        if not isinstance(self.node, yaml.ScalarNode):
            raise self.fail("expected a single value")
        return yaml.safe_load(self.node.value) if self.node.style is None else self.node.value

    def str(self) -> str:
        v = self._scalar()
        if not isinstance(v, str):
            raise self.fail(f"expected a name, got {v!r}")
        return v

    def float(self) -> float:
        v = self._scalar()
        if isinstance(v, str) and self.node.style is None:
            try:
                v = float(v)  # YAML 1.1 reads 1e-3 (no dot) as a string
            except ValueError:
                pass
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise self.fail(f"expected a number, got {v!r}")
        return float(v)

    def int(self, minimum: int | None = None) -> int:
        v = self._scalar()
        if isinstance(v, bool) or not isinstance(v, int):
            raise self.fail(f"expected an integer, got {v!r}")
        if minimum is not None and v < minimum:
            raise self.fail(f"must be >= {minimum}, got {v}")
        return v

    def bool(self) -> bool:
        v = self._scalar()
        if not isinstance(v, bool):
            raise self.fail(f"expected true or false, got {v!r}")
        return v

    def vec(self, n: int | tuple[int, ...], each: str = "float") -> tuple[float, ...]:
        """n numbers (or one of the sizes n lists), each read by the method `each` names
        (float, finite, positive), so an error names the number's own field."""
        sizes = (n,) if isinstance(n, int) else n
        items = self.list()
        if len(items) not in sizes:
            raise self.fail(f"expected {' or '.join(map(str, sizes))} numbers, got {len(items)}")
        return tuple(getattr(f, each)() for f in items)

    def ints(self, n: int, minimum: int | None = None) -> tuple[int, ...]:
        items = self.list()
        if len(items) != n:
            raise self.fail(f"expected {n} integers, got {len(items)}")
        return tuple(f.int(minimum) for f in items)

    def positive(self) -> float:
        v = self.float()
        if not v > 0 or not math.isfinite(v):
            raise self.fail(f"must be positive, got {v}")
        return v

    def finite(self) -> float:
        v = self.float()
        if not math.isfinite(v):
            raise self.fail(f"must be finite, got {v}")
        return v


def read_fields(path: Path) -> Field:
    """The YAML file at `path` as its top field; a file that is no YAML, or empty, raises
    SceneFileError naming file:line."""
    path = Path(path)
    text = path.read_text()
    try:
        node = yaml.compose(text)
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        where = f"{path}:{mark.line + 1}" if mark else str(path)
        raise SceneFileError(f"{where}: not valid YAML: {getattr(e, 'problem', e)}") from None
    if node is None:
        raise SceneFileError(f"{path}:1: the file is empty")
    return Field(node, str(path), "")
