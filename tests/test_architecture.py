"""The package's shape, read from its sources (issue 23): no import circle anywhere, ``simplify`` and ``synth``
on the model alone, and the command line and ``batch`` apart, both on the application layer.

The import graph is read with :mod:`ast` from every module of ``osm_expand``, ``simplify`` and ``synth``: every
import counts, at the top of a module, inside a function (the lazy imports that keep start-up fast) or under
``TYPE_CHECKING``, since each is a dependency a reader has to follow.
"""
from __future__ import annotations

import ast
from functools import cache
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("osm_expand", "simplify", "synth")


@cache
def modules() -> dict[str, Path]:
    """Every module of the three packages by dotted name (a package by its own name)."""
    found = {}
    for package in PACKAGES:
        for path in (ROOT / package).rglob("*.py"):
            parts = path.relative_to(ROOT).with_suffix("").parts
            found[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return found


@cache
def imports(name: str) -> frozenset[tuple[str, str]]:
    """``(module, imported name)`` pairs that module ``name`` imports from the three packages (name '' for
    ``import module``); ``from pkg import submodule`` counts as importing the submodule."""
    path = modules()[name]
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found |= {(a.name, "") for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*parts, base] if base else parts)
            for alias in node.names:
                sub = f"{base}.{alias.name}"
                found.add((sub, "") if sub in modules() else (base, alias.name))
    return frozenset((m, n) for m, n in found if m in modules() and m != name)


def graph() -> dict[str, set[str]]:
    return {name: {m for m, _ in imports(name)} for name in modules()}


def circles(g: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []
    for start in sorted(g):
        if start in index:
            continue
        work = [(start, iter(sorted(g[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            v, children = work[-1]
            for w in children:
                if w not in index:
                    index[w] = low[w] = len(index)
                    stack.append(w)
                    on_stack.add(w)
                    work.append((w, iter(sorted(g[w]))))
                    break
                if w in on_stack:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    component = []
                    while True:
                        w = stack.pop()
                        on_stack.discard(w)
                        component.append(w)
                        if w == v:
                            break
                    if len(component) > 1:
                        found.append(sorted(component))
    return found


def test_the_circle_finder_finds_a_circle():
    assert circles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert circles({"a": {"b"}, "b": set()}) == []


def test_no_module_imports_itself_back_through_others():
    assert circles(graph()) == []


def test_simplify_and_synth_import_only_the_model_of_osm_expand():
    """They build on the model (and the error base, a leaf that imports nothing); never on a stage."""
    allowed = ("osm_expand.model", "osm_expand.errors")
    for name in modules():
        if name.split(".")[0] in ("simplify", "synth"):
            used = {m for m, _ in imports(name) if m.split(".")[0] == "osm_expand"}
            assert all(any(m == a or m.startswith(a + ".") for a in allowed) for m in used), (name, used)
    assert imports("osm_expand.errors") == frozenset()


def test_the_command_line_and_batch_stand_apart_on_the_application_layer():
    """batch never imports the command line; the command line takes only batch's public names; both call
    osm_expand.app, which imports neither."""
    import osm_expand.batch

    batch = [name for name in modules() if name == "osm_expand.batch" or name.startswith("osm_expand.batch.")]
    from_batch_package = {m for name in batch for m, _ in imports(name)}
    assert len(batch) > 1  # the package and its modules: all of them are "batch" here
    assert "osm_expand.cli" not in from_batch_package
    from_batch = {n for m, n in imports("osm_expand.cli") if m == "osm_expand.batch"}
    assert from_batch and from_batch <= set(osm_expand.batch.__all__)
    assert not {m for m, _ in imports("osm_expand.cli") if m.startswith("osm_expand.batch.")}  # nor its modules
    assert {"osm_expand.app"} <= {m for m, _ in imports("osm_expand.cli")}
    assert {"osm_expand.app"} <= from_batch_package
    assert not {m for m, _ in imports("osm_expand.app")} & {"osm_expand.cli", *batch}
    for name in batch:
        source = modules()[name].read_text(encoding="utf-8")
        assert "argparse._" not in source and "._actions" not in source  # no argparse internals


def test_the_architecture_page_names_only_files_and_functions_that_exist():
    """docs/architecture.md's pictures and its "where is ..." table stay true to the code."""
    import re

    page = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    path = r"((?:osm_expand|simplify|synth|engine)/[\w/]*?(?:\.py|/(?!\w)))"
    named = re.findall(path + r"(?:`? *(?:\|? *`|: *)(\w+))?", page)
    assert len(named) > 40 and sum(bool(f) for _, f in named) > 30
    for path, function in named:
        where = ROOT / ("osm_expand/" + path if path.startswith("engine/") else path)
        assert where.exists(), path
        if function and where.suffix == ".py":
            source = where.read_text(encoding="utf-8")
            assert re.search(rf"^(def|class) {function}\b|^{function}\b.*=", source, re.M), (path, function)
    for question in ("where are roundabouts fused", "where is traffic assigned", "where are lots split"):
        assert question in page
