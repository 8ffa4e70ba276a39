"""The layout rules the code keeps: no import cycle between the Rust core's modules, the
add-on's modules, the helpers package or the scripts; the core's source grouped by area in
folders; tests import the helpers package, never a benchmark or another test, and nothing but
one conftest edits ``sys.path``."""

from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CORE = ROOT / "rust" / "core" / "src"


def _cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One cycle of ``graph`` (a list of nodes, first repeated last), or None."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                return stack[stack.index(nxt):] + [nxt]
            if nxt not in state and (found := visit(nxt)):
                return found
        stack.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state and (found := visit(node)):
            return found
    return None


def _rust_module(path: Path) -> str:
    parts = list(path.relative_to(CORE).with_suffix("").parts)
    if parts[-1] in ("mod", "lib"):
        parts.pop()
    return "::".join(["crate", *parts])


def rust_graph() -> dict[str, set[str]]:
    """Module -> the modules its non-test code names (``crate::a::b`` or ``super::x``)."""
    modules = {_rust_module(p): p for p in CORE.rglob("*.rs")}
    graph: dict[str, set[str]] = {}
    for name, path in modules.items():
        text = path.read_text()
        text = text.split("#[cfg(test)]")[0]
        text = re.sub(r"//[^\n]*", "", text)
        parent = name.rsplit("::", 1)[0]
        deps = set()
        for m in re.finditer(r"\b(crate|super)((?:::\w+)+)", text):
            base = "crate" if m.group(1) == "crate" else parent
            path_parts = [base, *m.group(2).strip(":").split("::")]
            # The longest prefix that is a module is what is used.
            for k in range(len(path_parts), 0, -1):
                target = "::".join(path_parts[:k])
                if target in modules:
                    break
            if target != name and target != "crate" and not name.startswith(target + "::"):
                deps.add(target)
        graph[name] = deps
    # A module uses its children's items through `mod x;` too.
    for name in modules:
        for m in re.finditer(r"^\s*(?:pub(?:\([\w:]+\))?\s+)?mod (\w+);", modules[name].read_text(), re.M):
            child = f"{name}::{m.group(1)}"
            if child in modules:
                graph[name].add(child)
    return graph


def python_graph(folder: Path, package: str | None) -> dict[str, set[str]]:
    """Module -> the modules of ``folder`` it imports (relative imports in a package, plain
    imports between sibling scripts)."""
    files = {p: p.relative_to(folder).with_suffix("") for p in folder.rglob("*.py")}
    names = {p: ".".join(r.parts[:-1] if r.name == "__init__" else r.parts) for p, r in files.items()}
    known = set(names.values())
    graph: dict[str, set[str]] = {}
    for path, name in names.items():
        deps = set()
        is_pkg = path.name == "__init__.py"
        here = name.split(".") if name else []
        pkg = here if is_pkg else here[:-1]
        for node in ast.walk(ast.parse(path.read_text())):
            targets = []
            if isinstance(node, ast.ImportFrom):
                if node.level:
                    base = pkg[: len(pkg) - (node.level - 1)] if node.level > 1 else pkg
                    mod = [*base, *(node.module.split(".") if node.module else [])]
                elif package is None and node.module:
                    mod = node.module.split(".")
                elif node.module and node.module.split(".")[0] == package:
                    mod = node.module.split(".")[1:]  # `from package import x`, `from package.x import y`
                else:
                    continue
                subs = [".".join([*mod, a.name]) for a in node.names]
                # `from . import x` names the module x; `from .x import y` names x.
                targets += [t for t in subs if t in known] or [".".join(mod)]
            elif isinstance(node, ast.Import) and package is None:
                targets += [a.name for a in node.names]
            for t in targets:
                if t in known and t != name:
                    deps.add(t)
        graph[name] = deps
    return graph


def test_the_rust_core_has_no_import_cycle():
    graph = rust_graph()
    assert len(graph) > 20
    assert _cycle(graph) is None, " -> ".join(_cycle(graph))


def test_the_checker_finds_a_cycle():
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b"}, "b": set(), "c": {"a"}}) is None


def test_the_addon_has_no_import_cycle():
    graph = python_graph(ROOT / "addon", "miniskeleton")
    assert len(graph) > 10
    assert _cycle(graph) is None, " -> ".join(_cycle(graph))


def test_the_scripts_have_no_import_cycle():
    graph = python_graph(ROOT / "scripts", None)
    assert _cycle(graph) is None, " -> ".join(_cycle(graph))


def test_the_helpers_have_no_import_cycle():
    graph = python_graph(ROOT / "testkit", "testkit")
    assert len(graph) > 8 and graph["builders"], graph
    assert _cycle(graph) is None, " -> ".join(_cycle(graph))


PYTHON_FOLDERS = ("addon", "bench", "blender_tests", "release_tests", "scripts", "testkit", "tests", "fuzz")


def _imports(path: Path) -> set[str]:
    """The absolute module names ``path`` imports (``from a.b import c`` gives a.b and a.b.c)."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
            out |= {node.module} | {f"{node.module}.{a.name}" for a in node.names}
    return out


def test_tests_import_neither_a_benchmark_nor_another_test():
    tests = {p.stem for d in ("blender_tests", "tests", "release_tests") for p in (ROOT / d).glob("test_*.py")}
    benches = {p.stem for p in (ROOT / "bench").glob("*.py")} - {"__init__"}
    bad = []
    for d in ("blender_tests", "tests", "release_tests", "testkit"):
        for path in sorted((ROOT / d).glob("*.py")):
            for name in _imports(path):
                top = name.split(".")
                if top[0] in tests or top[0] == "bench" or top[0] in benches or top[-1] in tests:
                    bad.append(f"{path.relative_to(ROOT)}: {name}")
    assert not bad, bad


def test_only_one_conftest_edits_sys_path():
    """Tests, benches and scripts import the helpers package testkit/ (pytest's ``pythonpath``
    in pyproject.toml, ``python -m`` from the checkout in the Makefile); the release checks'
    conftest alone puts scripts/platforms/ on the path for the platform build script."""
    edits = []
    for d in PYTHON_FOLDERS:
        for path in sorted((ROOT / d).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text())):
                if isinstance(node, ast.Attribute) and node.attr == "path" and \
                        isinstance(node.value, ast.Name) and node.value.id == "sys":
                    edits.append(str(path.relative_to(ROOT)))
    assert sorted(set(edits)) == ["release_tests/conftest.py"], sorted(set(edits))


def test_the_addon_imports_the_native_core_in_one_module():
    """``addon/common/native.py`` is the one door to ``miniskeleton_core``; every other module
    of the add-on gets the core from it."""
    importers = sorted(str(p.relative_to(ROOT)) for p in (ROOT / "addon").rglob("*.py")
                       if any(n.split(".")[0] == "miniskeleton_core" for n in _imports(p)))
    assert importers == ["addon/common/native.py"], importers


def test_the_core_is_grouped_by_area():
    flat = sorted(p.name for p in CORE.glob("*.rs"))
    assert len(flat) <= 6, flat
    for area in ("mesh", "weights", "weights/heat", "skeleton", "motion", "posing"):
        assert (CORE / area / "mod.rs").is_file(), area
