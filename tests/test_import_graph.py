"""The layers point one way: proto <- learner <- actors <- services (docs/architecture.md).

Read from the source (every import statement, at module level or inside a function): no
module imports a package above its own, proto imports nothing of ours, no set of modules
imports each other in a circle, and no set of folders does either: within every package, its
rooms (sub-packages and modules) import each other one way."""
from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LAYERS = {"proto": 0, "learner": 1, "actors": 2, "services": 3}


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def import_graph() -> dict[str, set[str]]:
    modules = {_module_name(p): p for top in LAYERS for p in (ROOT / top).rglob("*.py")}
    graph: dict[str, set[str]] = {}
    for name, path in modules.items():
        targets = set()
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                base = node.module
                # `from pkg import sub` imports the submodule when there is one.
                targets.update(f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base for a in node.names)
            elif isinstance(node, ast.ImportFrom):
                raise AssertionError(f"{path}: relative import; the project uses absolute ones")
            elif isinstance(node, ast.Import):
                targets.update(a.name for a in node.names)
        graph[name] = {t for t in targets if t.split(".")[0] in LAYERS and t in modules}
    return graph


def test_no_import_points_up_a_layer():
    upward = sorted(f"{m} -> {t}" for m, ts in import_graph().items() for t in ts
                    if LAYERS[t.split(".")[0]] > LAYERS[m.split(".")[0]] or (m.startswith("proto") and not t.startswith("proto")))
    assert not upward, upward


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan, iterative)."""
    index, low, on_stack, stack, found, counter = {}, {}, set(), [], [], [0]
    for start in graph:
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = counter[0]
        counter[0] += 1
        stack.append(start)
        on_stack.add(start)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = counter[0]
                    counter[0] += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def test_no_modules_import_each_other_in_a_circle():
    assert _cycles(import_graph()) == []


def room_graphs(graph: dict[str, set[str]]) -> dict[str, dict[str, set[str]]]:
    """Per package, the imports between its rooms (its sub-packages and modules, each with all
    it holds): `a.b.x -> a.c.y` is the edge `a.b -> a.c` inside package `a`."""
    rooms: dict[str, dict[str, set[str]]] = {}
    for module, targets in graph.items():
        for target in targets:
            a, b = module.split("."), target.split(".")
            k = 0
            while k < min(len(a), len(b)) and a[k] == b[k]:
                k += 1
            if k in (len(a), len(b)):  # a package and what it holds
                continue
            inside = rooms.setdefault(".".join(a[:k]), {})
            inside.setdefault(".".join(a[:k + 1]), set()).add(".".join(b[:k + 1]))
            inside.setdefault(".".join(b[:k + 1]), set())
    return rooms


def test_no_folders_import_each_other_in_a_circle():
    circles = {package: found for package, inside in room_graphs(import_graph()).items() if (found := _cycles(inside))}
    assert circles == {}


def test_the_room_graph_sees_a_circle_between_folders():
    graph = {"p.a.x": {"p.b.y"}, "p.b.y": set(), "p.b.z": {"p.a.w"}, "p.a.w": set()}
    assert {k: _cycles(v) for k, v in room_graphs(graph).items()} == {"p": [["p.a", "p.b"]]}


def test_the_cycle_finder_finds_a_circle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def _imported_tops(path: Path) -> set[str]:
    tops = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            tops.add(node.module.split(".")[0])
        elif isinstance(node, ast.Import):
            tops.update(a.name.split(".")[0] for a in node.names)
    return tops


def test_the_package_imports_nothing_that_is_not_installed():
    """bench/ (study scripts) and tests/ are not installed, so no installed module may import them."""
    offenders = sorted(str(p.relative_to(ROOT)) for top in LAYERS for p in (ROOT / top).rglob("*.py")
                       if _imported_tops(p) & {"bench", "tests"})
    assert not offenders, offenders
