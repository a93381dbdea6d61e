"""The package's shape, checked from the source: one ``kinegym.*`` namespace, dependencies that
point one way (``kinegym.cli -> agents -> envs -> kinematics, vision -> configs``), no import
cycle, the pure-numpy packages free of pymunk / gymnasium / GUI toolkits, every subpackage
found by the packaging, and source files short enough to read."""

from __future__ import annotations

import ast
import importlib.util
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: repository folder -> installed package (setup.py's mapping)
FOLDERS = {"kinegym": "kinegym", "configs": "kinegym.configs", "kinematics": "kinegym.kinematics",
           "vision": "kinegym.vision", "envs": "kinegym.envs", "agents": "kinegym.agents"}
#: the layers, lowest first; a module may import its own layer and the ones below
LAYER = {"kinegym.configs": 0, "kinegym.kinematics": 1, "kinegym.vision": 1, "kinegym.envs": 2,
         "kinegym.agents": 3, "kinegym": 4}
#: packages that are pure numpy / OpenCV: usable on a lab PC without physics, RL or a screen
PURE = ("kinegym.configs", "kinegym.kinematics", "kinegym.vision")
FORBIDDEN_IN_PURE = ("pymunk", "gymnasium", "pygame", "tkinter", "PySide6", "PyQt5", "PyQt6", "stable_baselines3",
                     "sb3_contrib", "torch")
#: files allowed past ~600 lines, each with the reason the README's architecture section gives
LONG_FILES: dict[str, str] = {}
MAX_LINES = 600


def _modules() -> dict[str, Path]:
    out = {}
    for folder, package in FOLDERS.items():
        for path in sorted((ROOT / folder).rglob("*.py")):
            rel = path.relative_to(ROOT / folder).with_suffix("")
            parts = [p for p in rel.parts if p != "__init__"]
            out[".".join([package, *parts])] = path
    return out


MODULES = _modules()


def _walk(tree: ast.AST):  # noqa: ANN202 - an iterator of nodes
    """``ast.walk`` less the ``if TYPE_CHECKING:`` blocks (annotations only, never run)."""
    todo = [tree]
    while todo:
        node = todo.pop()
        if isinstance(node, ast.If) and isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING":
            todo.extend(node.orelse)
            continue
        yield node
        todo.extend(ast.iter_child_nodes(node))


def _imports(name: str, path: Path) -> set[str]:
    """Every module ``name`` imports, at any depth of its code (top level or inside functions)."""
    tree = ast.parse(path.read_text(), str(path))
    is_pkg = path.name == "__init__.py"
    out: set[str] = set()
    for node in _walk(tree):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = name.split(".")
                base = base[: len(base) - node.level + (1 if is_pkg else 0)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            out.add(mod)
            out.update(f"{mod}.{a.name}" for a in node.names if f"{mod}.{a.name}" in MODULES)
    return out


IMPORTS = {name: _imports(name, path) for name, path in MODULES.items()}


def _layer(module: str) -> tuple[str, int]:
    for package in sorted(LAYER, key=len, reverse=True):
        if module == package or module.startswith(package + "."):
            return package, LAYER[package]
    raise KeyError(module)


def test_every_module_imports_through_the_namespace() -> None:
    old = {"configs", "kinematics", "vision", "envs", "agents"}
    bad = {n: sorted(m for m in mods if m.split(".")[0] in old) for n, mods in IMPORTS.items()}
    assert not {n: m for n, m in bad.items() if m}, "top-level names shadow users' own folders; use kinegym.*"


def test_dependencies_point_one_way() -> None:
    upward = []
    for name, mods in IMPORTS.items():
        pkg, rank = _layer(name)
        for m in mods:
            if m.split(".")[0] != "kinegym":
                continue
            other, other_rank = _layer(m)
            sideways = rank == other_rank and pkg != other  # kinematics <-> vision
            if other_rank > rank or sideways:
                upward.append(f"{name} -> {m}")
    assert not upward, "imports against the layering: " + ", ".join(sorted(upward))


def test_the_pure_packages_need_no_physics_rl_or_screen() -> None:
    bad = [f"{n} -> {m}" for n, mods in IMPORTS.items() if n.startswith(PURE)
           for m in mods if m.split(".")[0] in FORBIDDEN_IN_PURE]
    assert not bad, bad


def test_no_import_cycle() -> None:
    graph = {n: {m for m in mods if m in MODULES and m != n} for n, mods in IMPORTS.items()}
    # a package's __init__ importing its own submodules is how packages re-export: not a cycle
    for n in graph:
        if MODULES[n].name == "__init__.py":
            graph[n] = {m for m in graph[n] if not m.startswith(n + ".")}
    state: dict[str, int] = {}
    path: list[str] = []

    def visit(n: str) -> None:
        state[n] = 1
        path.append(n)
        for m in sorted(graph[n]):
            if state.get(m) == 1:
                raise AssertionError("import cycle: " + " -> ".join(path[path.index(m):] + [m]))
            if m not in state:
                visit(m)
        path.pop()
        state[n] = 2

    for n in sorted(graph):
        if n not in state:
            visit(n)


@pytest.mark.parametrize("package", sorted({n for n, p in MODULES.items() if p.name == "__init__.py"}))
def test_every_package_is_found_where_it_lies(package: str) -> None:
    """What setup.py discovers is what the source holds: each folder with an __init__.py
    imports as kinegym.<its path> from its own folder (editable install and wheel alike)."""
    spec = importlib.util.find_spec(package)
    assert spec is not None and spec.origin is not None, package
    assert Path(spec.origin).resolve() == MODULES[package].resolve()


def test_the_shipped_data_is_package_data() -> None:
    text = (ROOT / "setup.py").read_text()
    assert '"kinegym.configs": ["**/*.yaml"]' in text and '"kinegym.agents": ["data/*.npz"]' in text
    assert list((ROOT / "agents" / "data").glob("*.npz")) and list((ROOT / "configs").rglob("*.yaml"))


def test_source_files_stay_readable() -> None:
    long = {str(p.relative_to(ROOT)): n for p in MODULES.values() if (n := len(p.read_text().splitlines())) > MAX_LINES}
    unexplained = {f: n for f, n in long.items() if f not in LONG_FILES}
    assert not unexplained, f"files over {MAX_LINES} lines without a reason in the README: {unexplained}"
    readme = (ROOT / "README.md").read_text()
    assert all(f in readme for f in LONG_FILES), "each long file's reason belongs in the README's architecture"
