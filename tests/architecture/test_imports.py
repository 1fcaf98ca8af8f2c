"""The package's import graph: no cycles, imports only downward (DESIGN.md: data flow).

Every ``import`` in ``mechkin/`` is read from the source (module level and inside functions;
``if TYPE_CHECKING:`` blocks are annotations only and skipped). No edge is exempt: records know
nothing of io (``Report.write`` calls the writer that ``mechkin.tasks`` installs), and the task
layer reaches io only through ``mechkin.tasks.write``. Inside ``solvers/`` each room
(sub-package) imports only the rooms docs/ARCHITECTURE.md allows (:mod:`test_rooms`).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PKG = Path(__file__).resolve().parents[2] / "mechkin"

# layer -> layers it must never import
FORBIDDEN = {
    "spatial": {"config", "model", "solvers", "tasks", "io", "records", "cli", "api"},
    "config": {"model", "solvers", "tasks", "io", "records", "cli", "api"},
    "model": {"solvers", "tasks", "io", "records", "cli", "api"},
    "solvers": {"tasks", "io", "cli", "api"},
    "records": {"config", "model", "solvers", "tasks", "cli", "api"},
    "io": {"config", "model", "solvers", "tasks", "cli", "api"},
    "tasks": {"cli", "api"},  # io: only mechkin.tasks.write (test_tasks_reach_io_through_write)
    "api": {"cli", "io"},
    "solver": {"cli", "io", "api"},
    "errors": {"config", "model", "solvers", "tasks", "io", "records", "cli", "api", "spatial"},
}
#: the task layer's one door to io (Report.write's writer)
TASKS_WRITE = "mechkin.tasks.write"


def _module_name(path: Path) -> str:
    rel = path.relative_to(PKG.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _is_type_checking(node: ast.If) -> bool:
    t = node.test
    return (isinstance(t, ast.Name) and t.id == "TYPE_CHECKING") or (
        isinstance(t, ast.Attribute) and t.attr == "TYPE_CHECKING")


def _imports(path: Path, mod: str) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    out: set[str] = set()
    is_pkg = path.name == "__init__.py"

    def visit(node: ast.AST) -> None:
        if isinstance(node, ast.If) and _is_type_checking(node):
            for n in node.orelse:
                visit(n)
            return
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name.startswith("mechkin"))
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = mod.split(".") if is_pkg else mod.split(".")[:-1]
                base = base[: len(base) - node.level + 1]
                name = ".".join(base + ([node.module] if node.module else []))
            else:
                name = node.module or ""
            if name.startswith("mechkin"):
                out.add(name)
                for a in node.names:  # from mechkin.io import atomic -> mechkin.io.atomic
                    out.add(f"{name}.{a.name}")
        for child in ast.iter_child_nodes(node):
            visit(child)

    visit(tree)
    return out


def _graph() -> dict[str, set[str]]:
    files = {_module_name(p): p for p in PKG.rglob("*.py")}
    graph: dict[str, set[str]] = {}
    for mod, path in files.items():
        deps = set()
        for name in _imports(path, mod):
            while name and name not in files:  # 'from x import func' -> x
                name = name.rpartition(".")[0]
            if name and name != mod:
                deps.add(name)
        graph[mod] = deps
    return graph


def _layer(mod: str) -> str:
    parts = mod.split(".")
    return parts[1] if len(parts) > 1 else "mechkin"


GRAPH = _graph()


def test_graph_covers_the_package():
    assert "mechkin.tasks.fk" in GRAPH and "mechkin.io.report" in GRAPH
    assert "mechkin.records" in GRAPH["mechkin.io.report"]


@pytest.mark.parametrize("mod", sorted(GRAPH))
def test_no_forbidden_direction(mod):
    bad = []
    for dep in GRAPH[mod]:
        if _layer(dep) in FORBIDDEN.get(_layer(mod), set()):
            bad.append(dep)
        if _layer(dep) == "cli" and _layer(mod) != "cli" and mod != "mechkin.__main__":
            bad.append(dep)
    assert not bad, f"{mod} imports {sorted(set(bad))}"


def test_no_import_cycle():
    graph = {m: set(deps) for m, deps in GRAPH.items()}
    # package __init__ re-exporting its own submodules is not a cycle of behaviour
    for m, deps in graph.items():
        graph[m] = {d for d in deps if not (d.startswith(m + ".") or m.startswith(d + ".")
                                            and d != "mechkin")}
    graph["mechkin"] = set()
    state: dict[str, int] = {}
    stack: list[str] = []
    cycles: list[list[str]] = []

    def dfs(u: str) -> None:
        state[u] = 1
        stack.append(u)
        for v in sorted(graph.get(u, ())):
            if state.get(v) == 1:
                cycles.append(stack[stack.index(v):] + [v])
            elif v not in state:
                dfs(v)
        stack.pop()
        state[u] = 2

    for m in sorted(graph):
        if m not in state:
            dfs(m)
    assert not cycles, "import cycles: " + "; ".join(" -> ".join(c) for c in cycles[:5])


def test_tasks_reach_io_through_write():
    """Tasks write no files; the one task module that imports io is the writer behind
    ``Report.write`` (mechkin.tasks.write), and it imports only io's entry point."""
    bad = {m: sorted(d for d in deps if _layer(d) == "io")
           for m, deps in GRAPH.items() if _layer(m) == "tasks"}
    assert {m: d for m, d in bad.items() if d and m != TASKS_WRITE} == {}
    assert bad[TASKS_WRITE] == ["mechkin.io.report"]


def test_records_know_nothing_of_io():
    assert not [d for m, deps in GRAPH.items() if _layer(m) == "records"
                for d in deps if _layer(d) == "io"]


# ---- the rooms of solvers/ (docs/ARCHITECTURE.md keeps the table; this test keeps it true) ----

ARCH = PKG.parent / "docs" / "ARCHITECTURE.md"


def _table(marker: str) -> list[list[str]]:
    """The rows of the markdown table after the ``<!-- marker: ...`` comment, cells stripped
    of backticks."""
    lines = ARCH.read_text(encoding="utf-8").splitlines()
    start = next(i for i, ln in enumerate(lines) if ln.startswith(f"<!-- {marker}:"))
    rows = []
    for ln in lines[start + 3:]:  # comment, header, separator
        if not ln.startswith("|"):
            break
        rows.append([c.strip().replace("`", "") for c in ln.strip().strip("|").split("|")])
    return rows


ROOMS = {row[0]: {r.strip() for r in row[2].split(",") if r.strip()} for row in _table("rooms")}


def _room(mod: str) -> str | None:
    parts = mod.split(".")
    return parts[2] if len(parts) > 2 and parts[1] == "solvers" else None


def test_every_room_has_a_row():
    have = {p.stem if p.is_file() else p.name for p in (PKG / "solvers").iterdir()
            if (p.suffix == ".py" and p.stem != "__init__") or (p / "__init__.py").is_file()}
    assert have == set(ROOMS), (f"docs/ARCHITECTURE.md rooms: missing "
                                f"{sorted(have - set(ROOMS))}, stale {sorted(set(ROOMS) - have)}")
    for room, allowed in ROOMS.items():
        assert allowed <= set(ROOMS) - {room}, (room, allowed)


@pytest.mark.parametrize("room", sorted(ROOMS))
def test_room_imports_only_the_rooms_it_may(room):
    bad = sorted({f"{m} -> {d}" for m, deps in GRAPH.items() if _room(m) == room
                  for d in deps if _room(d) not in (None, room) and _room(d) not in ROOMS[room]})
    assert not bad, f"room {room} may import {sorted(ROOMS[room])} only: {bad}"


def test_rooms_form_no_cycle():
    import graphlib

    order = graphlib.TopologicalSorter({r: set(a) for r, a in ROOMS.items()})
    order.prepare()  # raises CycleError on a cycle of allowed imports


PAPERS = _table("papers")


def test_papers_table_names_real_functions():
    assert {row[0] for row in PAPERS} >= {"kim1995", "hwang2023", "park", "lee"}
    missing = []
    for _paper, _eqs, module, name in PAPERS:
        path = PKG.parent / Path(*module.split("."))
        path = path / "__init__.py" if path.is_dir() else path.with_suffix(".py")
        tree = ast.parse(path.read_text(encoding="utf-8")) if path.is_file() else None
        names = {n.name for n in (tree.body if tree else [])
                 if isinstance(n, ast.FunctionDef | ast.ClassDef)}
        if name not in names:
            missing.append(f"{module}.{name}")
    assert not missing, f"docs/ARCHITECTURE.md names what does not exist: {missing}"


@pytest.mark.parametrize("room", sorted(r for r in ROOMS if (PKG / "solvers" / r).is_dir()))
def test_room_docstring_says_what_it_may_import(room):
    doc = ast.get_docstring(ast.parse((PKG / "solvers" / room / "__init__.py").read_text()))
    assert doc and "import" in doc, f"mechkin/solvers/{room}/__init__.py: no docstring saying " \
                                    "what it owns and may import"
