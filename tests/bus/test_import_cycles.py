"""No import circles inside hitrobot_server: the module import graph, read with ``ast`` (every
import, also those inside functions and ``TYPE_CHECKING`` blocks), has no cycle. A circle
makes a reader hold two modules in mind at once, and works only while the imports happen to
run in the right order (bus/ had two: ``action_interfaces`` ↔ ``core``, ``encoded`` ↔
``topics``)."""

from __future__ import annotations

import ast
from pathlib import Path

import hitrobot_server

PACKAGE = Path(hitrobot_server.__file__).parent


def project_sources() -> dict[str, tuple[str, bool]]:
    """Every module of the project: dotted name → (source, is a package's ``__init__``)."""
    found = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = [PACKAGE.name, *path.relative_to(PACKAGE).with_suffix("").parts]
        is_package = parts[-1] == "__init__"
        name = ".".join(parts[:-1] if is_package else parts)
        found[name] = (path.read_text(encoding="utf-8"), is_package)
    return found


def imports_of(name: str, source: str, is_package: bool, modules: set[str]) -> set[str]:
    """The project modules ``name`` imports; ``from pkg import mod`` names the module ``mod``."""
    here = name.split(".") if is_package else name.split(".")[:-1]
    root = name.split(".")[0]
    found: set[str] = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names if a.name.split(".")[0] == root}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = ".".join(here[: len(here) - (node.level - 1)])
                target = f"{base}.{node.module}" if node.module else base
            elif node.module and node.module.split(".")[0] == root:
                target = node.module
            else:
                continue
            subs = {f"{target}.{a.name}" for a in node.names} & modules
            found |= subs or {target}
    return {_existing(m, modules) for m in found} - {name, None}


def _existing(module: str, modules: set[str]) -> str | None:
    """The module itself, or the nearest package holding it (``a.b.C`` → ``a.b``)."""
    parts = module.split(".")
    while parts and ".".join(parts) not in modules:
        parts.pop()
    return ".".join(parts) or None


def import_graph(sources: dict[str, tuple[str, bool]]) -> dict[str, set[str]]:
    modules = set(sources)
    return {name: imports_of(name, src, is_pkg, modules) for name, (src, is_pkg) in
            sources.items()}


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected groups of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while True:
                w = stack.pop()
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                found.append(sorted(group))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_no_import_cycles():
    found = cycles(import_graph(project_sources()))
    assert not found, "import cycles:\n" + "\n".join(" ↔ ".join(c) for c in found)


def test_the_rule_catches_a_cycle():
    """The checker itself: a circle through a relative import, a ``from pkg import module``
    and a ``TYPE_CHECKING`` import is found; imports of packages and names are not circles."""
    sources = {
        "hitrobot_server": ("", True),
        "hitrobot_server.bus": ("", True),
        "hitrobot_server.bus.core": ("from .topics import Topic\n", False),
        "hitrobot_server.bus.topics": ("from . import tap\n", False),
        "hitrobot_server.bus.tap": (
            "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
            "    from hitrobot_server.bus.core import Bus\n", False),
        "hitrobot_server.bus.names": ("from ..bus import Bus\nimport os\n", False),
    }
    graph = import_graph(sources)
    assert graph["hitrobot_server.bus.topics"] == {"hitrobot_server.bus.tap"}
    assert graph["hitrobot_server.bus.names"] == {"hitrobot_server.bus"}  # a name of a package
    assert cycles(graph) == [["hitrobot_server.bus.core", "hitrobot_server.bus.tap",
                              "hitrobot_server.bus.topics"]]
    sources["hitrobot_server.bus.tap"] = ("from .names import canonical\n", False)
    assert cycles(import_graph(sources)) == []
