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


#: The command line's shared modules: the only cli modules a command module imports.
CLI_SHARED = {"avtrack.cli", "avtrack.cli.base", "avtrack.cli.progress"}


def test_no_command_module_imports_another():
    """The commands meet in the pipeline layer, not in each other: a cli module imports only
    the command line's shared helpers (``cli.base``, ``cli.progress``), except the entry point
    ``cli.main``, which registers them, and the batch runner's modules, which run them through
    ``cli.main``'s parsers."""

    def allowed(a: str, b: str) -> bool:
        if b in CLI_SHARED or a == "avtrack.cli.main":
            return True
        return a.startswith("avtrack.cli.batch") and (
            b.startswith("avtrack.cli.batch") or b == "avtrack.cli.main")

    bad = [f"{a} -> {b}" for a, targets in _imports().items() if a.startswith("avtrack.cli.")
           for b in targets if b.startswith("avtrack.cli") and not allowed(a, b)]
    assert bad == []


def test_no_benchmark_imports_the_command_line():
    bench = Path(__file__).resolve().parents[1] / "benchmarks"
    if not bench.is_dir():
        import pytest

        pytest.skip("benchmarks/ not next to tests/ (tests copied without the checkout)")
    bad = []
    for path in sorted(bench.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            names = ([node.module or ""] if isinstance(node, ast.ImportFrom)
                     else [a.name for a in node.names] if isinstance(node, ast.Import) else [])
            bad += [f"{path.name} -> {n}" for n in names if n.startswith("avtrack.cli")]
    assert bad == []
