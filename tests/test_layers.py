"""The package's layers: each subpackage imports only those below it, and no module imports
itself back through others (no import circle).

The order is the README's layout section, bottom up; packages on one line do not import each
other.
"""

import ast
from pathlib import Path

import avtrack

LAYERS = [
    ["errors", "_jit"],
    ["config", "registry"],
    ["io"],
    ["audio", "metrics"],
    ["vem"],
    ["visual", "localize", "doa"],
    ["av", "phd"],
    ["robot"],
    ["simulate"],
    ["viz"],
    ["stream"],
    ["pipelines"],
    ["cli"],
    ["__main__"],
]
RANK = {name: i for i, names in enumerate(LAYERS) for name in names}
ROOT = Path(avtrack.__file__).parent


def _module_name(path: Path) -> str:
    parts = ["avtrack", *path.relative_to(ROOT).with_suffix("").parts]
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports() -> dict[str, set[str]]:
    """Module -> the avtrack modules it imports (anywhere in the file)."""
    modules = {_module_name(p): p for p in ROOT.rglob("*.py")}
    out: dict[str, set[str]] = {}
    for name, path in modules.items():
        found = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                for alias in node.names:
                    full = f"{node.module}.{alias.name}"
                    found.add(full if full in modules else node.module)
            elif isinstance(node, ast.Import):
                found.update(a.name for a in node.names)
        out[name] = {m for m in found if m.startswith("avtrack") and m != name}
    return out


def _package(module: str) -> str:
    return module.split(".")[1] if "." in module else ""


def test_every_package_has_a_layer():
    packages = {_package(m) for m in _imports()} - {""}
    assert packages == set(RANK)


def test_no_import_from_a_lower_layer_to_a_higher_one():
    bad = [
        f"{a} -> {b}"
        for a, targets in _imports().items()
        for b in targets
        if _package(a) and _package(b) and _package(a) != _package(b)
        and RANK[_package(b)] >= RANK[_package(a)]
    ]
    assert bad == []


def test_no_import_circle():
    graph = _imports()
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    circles = []

    def visit(node: str, path: list[str]) -> None:
        state[node] = 1
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                circles.append([*path[path.index(nxt):], nxt])
            elif nxt not in state:
                visit(nxt, [*path, nxt])
        state[node] = 2

    for start in sorted(graph):
        if start not in state:
            visit(start, [start])
    assert circles == []
