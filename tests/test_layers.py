"""The import structure: no module takes another module's private names, and no import
cycle, counting imports inside functions. The layer contracts themselves are
import-linter's (``[tool.importlinter]`` in pyproject.toml, run by ``lint-imports`` in
.ci/run); import-linter has no contract for private names, hence the walk here."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parent.parent / "volpack"

# The io package's helpers that octree sources and batch planning still take by their
# private names; the io split (one module per format) gives them public ones.
PENDING = {
    ("volpack.batch.planning", "volpack.io._EXTENSIONS"),
    ("volpack.octree.source", "volpack.io._h5_pick"),
    ("volpack.octree.source", "volpack.io._h5_geometry"),
    ("volpack.octree.source", "volpack.io._tiff_geometry"),
    ("volpack.octree.source", "volpack.io._tiff_xy_spacing"),
    ("volpack.octree.source", "volpack.io._natural_key"),
    ("volpack.octree.source", "volpack.io._wrap"),
    ("volpack.octree.source", "volpack.io._raw_check"),
}


def _modules() -> dict[str, Path]:
    out = {}
    for p in sorted(PACKAGE.rglob("*.py")):
        parts = list(p.relative_to(PACKAGE.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        out[".".join(parts)] = p
    return out


def _target(importer: str, is_package: bool, level: int, module: str | None) -> str:
    """The absolute module a ``from ... import`` names."""
    if level == 0:
        return module or ""
    base = importer.split(".")
    if not is_package:
        base.pop()
    base = base[: len(base) - (level - 1)]
    return ".".join(base + ([module] if module else []))


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def private_uses(modules: dict[str, Path]) -> list[tuple[str, int, str]]:
    """``(importer, line, what)`` for each ``from X import _name`` and each ``x._name`` of
    an imported volpack module ``x``, X another module; a private submodule may be
    imported by the modules of its own package."""
    found = []
    for name, path in modules.items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        is_package = path.name == "__init__.py"
        package = name if is_package else name.rpartition(".")[0]
        bound: dict[str, str] = {}
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                for a in node.names:
                    if a.name.startswith("volpack") and a.asname:
                        bound[a.asname] = a.name
            if not isinstance(node, ast.ImportFrom):
                continue
            target = _target(name, is_package, node.level, node.module)
            if not target.startswith("volpack") or target == name:
                continue
            for a in node.names:
                full = f"{target}.{a.name}"
                if full in modules:
                    bound[a.asname or a.name] = full
                    if _private(a.name) and target != package:
                        found.append((name, node.lineno, full))
                elif _private(a.name):
                    found.append((name, node.lineno, full))
        for node in ast.walk(tree):
            if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name):
                mod = bound.get(node.value.id)
                if mod and mod != name and _private(node.attr):
                    found.append((name, node.lineno, f"{mod}.{node.attr}"))
    return found


def test_no_module_imports_another_modules_private_names():
    bad = [u for u in private_uses(_modules()) if (u[0], u[2]) not in PENDING]
    assert not bad, "private names used across modules: " + "; ".join(
        f"{m}:{line} {what}" for m, line, what in bad
    )


def test_the_private_name_check_catches_what_it_should(tmp_path):
    pkg = tmp_path / "volpack"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "a.py").write_text("def _hidden():\n    pass\n")
    (pkg / "sub" / "__init__.py").write_text("")
    (pkg / "sub" / "_kern.py").write_text("")
    (pkg / "sub" / "b.py").write_text(
        "from .. import a\nfrom . import _kern\nfrom ..a import _hidden\n\n\n"
        "def f():\n    from .. import a as aa\n    return a._hidden, aa._hidden\n"
    )
    modules = {}
    for p in sorted(pkg.rglob("*.py")):
        parts = list(p.relative_to(tmp_path).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        modules[".".join(parts)] = p
    got = sorted(what for _, _, what in private_uses(modules))
    assert got == ["volpack.a._hidden"] * 3  # the sibling _kern module is allowed


def cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan, iteratively)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []
    for root in sorted(edges):
        if root in index:
            continue
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        work = [(root, iter(sorted(edges[root])))]
        while work:
            v, it = work[-1]
            w = next(it, None)
            if w is not None:
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(edges.get(w, ())))))
                elif w in on_stack:
                    low[v] = min(low[v], index[w])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[v])
            if low[v] == index[v]:
                comp = []
                while True:
                    w = stack.pop()
                    on_stack.discard(w)
                    comp.append(w)
                    if w == v:
                        break
                if len(comp) > 1:
                    found.append(sorted(comp))
    return found


def test_cycle_finder_on_a_known_graph():
    edges = {"a": {"b"}, "b": {"c"}, "c": {"a", "d"}, "d": {"e"}, "e": {"d"}, "f": {"a"}}
    assert sorted(cycles(edges)) == [["a", "b", "c"], ["d", "e"]]
    assert cycles({"a": {"b"}, "b": set()}) == []


def test_no_import_cycles_counting_imports_inside_functions():
    grimp = pytest.importorskip("grimp")
    graph = grimp.build_graph("volpack", cache_dir=None)
    edges = {m: set(graph.find_modules_directly_imported_by(m)) for m in graph.modules}
    found = cycles(edges)
    assert not found, f"import cycles: {found}"
