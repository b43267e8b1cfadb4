"""The import arrows of docs/architecture.md point one way: a stage imports only stages below it.

Parses every module of the package (no import is executed) and checks each ``dressmeup.*``
import against the layer table below, so that a cycle or an upward arrow fails here instead of
surfacing later as a circular import or a tangled design.
"""

from __future__ import annotations

import ast
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "dressmeup"

# Lowest first. A unit may import units of its own layer only when listed together in
# SIBLINGS_MAY_IMPORT; otherwise only units of lower layers.
LAYERS: list[set[str]] = [
    {"dressmeup", "errors", "cache", "progress", "io.atomic", "io.jsonable", "io.jsonio",
     "io.npz", "executors", "hyperparameters"},
    {"geometry"},
    {"metrics", "io.mesh"},
    {"body"},
    {"capture"},
    {"fusion"},
    {"extraction"},
    {"data"},
    {"methods.nn"},
    {"methods.retarget", "methods.uvparam"},
    {"bench"},
    {"viz"},
    {"demo"},
    {"cli", "__main__"},
]
SIBLINGS_MAY_IMPORT = {("dressmeup", "errors"), ("executors", "errors"), ("hyperparameters", "errors"), ("io.jsonio", "errors"), ("io.npz", "errors"), ("cli", "__main__"), ("__main__", "cli")}


def _unit(module: str) -> str | None:
    parts = module.split(".")
    if parts[0] != "dressmeup":
        return None
    if len(parts) == 1:
        return "dressmeup"
    if parts[1] in ("methods", "io") and len(parts) > 2:
        return f"{parts[1]}.{parts[2]}"
    return parts[1]


def _level(unit: str) -> int:
    for i, layer in enumerate(LAYERS):
        if unit in layer:
            return i
    raise AssertionError(f"unit {unit!r} is not in the layer table of tests/test_architecture.py")


def _imports() -> list[tuple[str, str, str]]:
    """(file, importing unit, imported unit) for every absolute dressmeup import."""
    out = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE.parent).with_suffix("")
        module = ".".join(rel.parts).removesuffix(".__init__")
        src = _unit(module)
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                names = [node.module]
            for name in names:
                dst = _unit(name)
                if dst is not None and dst != src:
                    out.append((str(rel), src, dst))
    return out


def test_every_unit_is_in_the_layer_table():
    units = {src for _, src, _ in _imports()} | {dst for _, _, dst in _imports()}
    for unit in units:
        _level(unit)


def test_imports_point_down_the_journey():
    upward = []
    for path, src, dst in _imports():
        ls, ld = _level(src), _level(dst)
        if ld > ls or (ld == ls and (src, dst) not in SIBLINGS_MAY_IMPORT):
            upward.append(f"{path}: {src} (layer {ls}) imports {dst} (layer {ld})")
    assert not upward, "imports against the architecture:\n" + "\n".join(upward)


def test_the_checker_sees_an_upward_import():
    # guard against a checker that silently finds nothing
    found = _imports()
    assert any(src == "bench" and dst == "metrics" for _, src, dst in found)
    assert _level("metrics") < _level("bench")


def _module_imports() -> dict[str, set[str]]:
    """Module -> the package modules it imports at module level (not inside functions).

    ``from a.b import c`` counts as an import of ``a.b.c`` when that is a module, else of
    ``a.b``; a package's ``__init__`` is the module ``a.b``. Imports under
    ``if TYPE_CHECKING:`` are left out (they never run).
    """
    modules = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE.parent).with_suffix("")
        modules[".".join(rel.parts).removesuffix(".__init__")] = path
    graph: dict[str, set[str]] = {}
    for module, path in modules.items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        out: set[str] = set()
        todo = list(tree.body)
        while todo:
            node = todo.pop()
            if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
                continue
            if isinstance(node, (ast.If, ast.Try, ast.With)):  # still module level
                todo.extend(ast.iter_child_nodes(node))
                continue
            if isinstance(node, ast.Import):
                out.update(a.name for a in node.names if a.name.startswith("dressmeup"))
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0 \
                    and node.module.startswith("dressmeup"):
                for a in node.names:
                    sub = f"{node.module}.{a.name}"
                    out.add(sub if sub in modules else node.module)
        graph[module] = {m for m in out if m in modules and m != module}
    return graph


def _find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One cycle of the directed graph as a list of nodes (first == last), or None."""
    state: dict[str, int] = {}  # 1 = on the stack, 2 = done
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(graph.get(node, ())):
            if state.get(nxt) == 1:
                return stack[stack.index(nxt):] + [nxt]
            if nxt not in state:
                found = visit(nxt)
                if found:
                    return found
        stack.pop()
        state[node] = 2
        return None

    for node in sorted(graph):
        if node not in state:
            found = visit(node)
            if found:
                return found
    return None


def test_module_level_imports_have_no_cycle():
    # a cycle works only as long as nobody reorders an import; the layers allow siblings
    # (e.g. two modules of one unit), so check the module graph itself
    cycle = _find_cycle(_module_imports())
    assert cycle is None, "module-level import cycle: " + " -> ".join(cycle)


def test_the_cycle_finder_finds_a_cycle():
    assert _find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": set()}) == ["a", "b", "c", "a"]
    assert _find_cycle({"a": {"b"}, "b": set()}) is None
    graph = _module_imports()
    assert "dressmeup.geometry.topology" in graph["dressmeup.geometry.uv_atlas"]
