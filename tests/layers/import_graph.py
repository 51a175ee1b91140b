"""The import graph of a source tree, read with `ast` (nothing is imported): every import
statement, at module level or inside a function, resolved to the module it loads, with its
file:line. The layer test (test_layers.py) checks this graph against the declared layers."""
from __future__ import annotations

import ast
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class Import:
    source: str   # the importing module
    target: str   # the module it loads
    file: Path
    line: int
    in_function: bool

    @property
    def where(self) -> str:
        return f"{self.file}:{self.line}"


class GraphError(ValueError):
    """A file that cannot be read as a module of the graph; the message names file:line."""


def modules(package_dir: Path) -> dict[str, Path]:
    """Every module of the package in `package_dir` (a folder with __init__.py): dotted name -> file."""
    package_dir = Path(package_dir)
    if not (package_dir / "__init__.py").is_file():
        raise GraphError(f"{package_dir}: no __init__.py, not a package")
    out = {}
    for f in sorted(package_dir.rglob("*.py")):
        parts = f.relative_to(package_dir.parent).with_suffix("").parts
        if any(not (package_dir.parent.joinpath(*parts[:i]) / "__init__.py").is_file() for i in range(1, len(parts))):
            continue  # a script in a folder that is no package (not importable as a module)
        out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = f
    return out


def _functions(tree: ast.AST) -> set[int]:
    """ids of the import nodes inside a function (def, async def, lambda) at any depth."""
    inside = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            inside.update(id(n) for n in ast.walk(node) if isinstance(n, (ast.Import, ast.ImportFrom)))
    return inside


def imports(files: dict[str, Path], packages: tuple[str, ...], extra: set[str] = frozenset()) -> list[Import]:
    """The imports among `files` (module -> file) of modules under `packages`; `extra` names
    modules that have no source here but may be imported (a compiled extension). An import of a
    module of `packages` that is neither raises GraphError naming file:line."""
    known = set(files) | set(extra)
    out = []
    for module, f in files.items():
        try:
            tree = ast.parse(f.read_text(), str(f))
        except SyntaxError as e:
            raise GraphError(f"{f}:{e.lineno}: not valid Python: {e.msg}") from None
        in_function = _functions(tree)
        package = module if f.name == "__init__.py" else module.rpartition(".")[0]
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                wanted = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    up = package.split(".")
                    if node.level - 1 >= len(up):
                        raise GraphError(f"{f}:{node.lineno}: relative import goes above the top package")
                    base = ".".join(up[:len(up) - node.level + 1] + ([node.module] if node.module else []))
                # `from p import name`: the submodule p.name where there is one, else p itself
                wanted = [f"{base}.{a.name}" if f"{base}.{a.name}" in known else base for a in node.names]
            else:
                continue
            for name in dict.fromkeys(wanted):
                if name.split(".")[0] not in packages:
                    continue
                if name not in known:  # Python would raise ModuleNotFoundError here
                    raise GraphError(f"{f}:{node.lineno}: imports {name}, which is no module here")
                out.append(Import(module, name, f, node.lineno, id(node) in in_function))
    return out


def cycles(edges: list[Import]) -> list[list[Import]]:
    """One cycle (its edges, in order) for each group of modules that import each other,
    directly or through others (Tarjan's strongly connected components)."""
    graph: dict[str, dict[str, Import]] = {}
    for e in edges:
        graph.setdefault(e.source, {}).setdefault(e.target, e)
    index, low, stack, on_stack, groups = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, {}):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = set()
            while True:
                w = stack.pop()
                on_stack.discard(w)
                group.add(w)
                if w == v:
                    break
            if len(group) > 1 or v in graph.get(v, {}):
                groups.append(group)

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return [_cycle_in(graph, group) for group in groups]


def _cycle_in(graph: dict, group: set) -> list[Import]:
    """A shortest cycle through the group's first module (breadth first), as its edges."""
    start = min(group)
    back = {start: None}
    queue = [start]
    while queue:
        v = queue.pop(0)
        for w, e in sorted(graph.get(v, {}).items()):
            if w == start:
                path = [e]
                while back[v] is not None:
                    path.append(back[v])
                    v = back[v].source
                return path[::-1]
            if w in group and w not in back:
                back[w] = e
                queue.append(w)
    raise AssertionError(f"no cycle through {start}")  # a strongly connected group always has one
