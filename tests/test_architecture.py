"""The import arrows of docs/architecture.md point one way: a stage imports only stages below it.

Parses every module of the package (no import is executed) and checks every ``dressmeup.*``
import, at module level and inside functions, against the layer table below; the whole
import graph (function-level imports included) must have no cycle; and an import inside a
function must say in a comment why it is not at module level (a heavy optional dependency,
start-up time of ``import dressmeup`` / ``dressmeup --help``).
"""

from __future__ import annotations

import ast
import io
import tokenize
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "dressmeup"

# Lowest first. A unit may import units of its own layer only when listed together in
# SIBLINGS_MAY_IMPORT; otherwise only units of lower layers.
LAYERS: list[set[str]] = [
    {"dressmeup", "errors", "limits", "cache", "progress", "io.atomic", "io.jsonable",
     "io.jsonio", "io.npz", "io.pickles", "io.images", "io.tables", "io.hashing", "io.outlock",
     "executors", "hyperparameters"},
    {"geometry", "io.ply", "io.obj"},
    {"metrics", "io.mesh"},
    {"body"},
    {"capture"},
    {"fusion"},
    {"extraction"},
    {"data"},
    {"bench"},
    {"methods.nn"},
    {"methods.retarget", "methods.uvparam"},
    {"viz", "runs"},
    {"server"},
    {"demo"},
    {"cli", "__main__"},
]
SIBLINGS_MAY_IMPORT = {("dressmeup", "errors"), ("executors", "errors"),
                       ("hyperparameters", "errors"), ("io.jsonio", "errors"),
                       ("io.npz", "errors"), ("cli", "__main__"), ("__main__", "cli"),
                       ("limits", "errors"),
                       *((unit, "limits") for unit in ("io.jsonio", "io.npz", "io.pickles",
                                                       "io.images", "io.tables",
                                                       "executors")),
                       *((unit, "errors") for unit in ("io.pickles", "io.images", "io.tables",
                                                       "io.outlock")),
                       ("executors", "io.jsonio")}
# what the evaluation devkit may import: it must never run or favour a method
BENCH_MAY_NOT_IMPORT = ("methods.nn", "methods.retarget", "methods.uvparam", "runs", "viz",
                        "server", "demo", "cli")


def _modules() -> dict[str, Path]:
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE.parent).with_suffix("")
        out[".".join(rel.parts).removesuffix(".__init__")] = path
    return out


MODULES = _modules()


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


def _type_checking_nodes(tree: ast.AST) -> set[int]:
    """ids of the import nodes under ``if TYPE_CHECKING:`` (they never run)."""
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            out |= {id(n) for n in ast.walk(node)}
    return out


def _targets(node: ast.AST, module: str, is_package: bool) -> set[str]:
    """The package modules an import node imports (``from a.b import c`` is ``a.b.c`` when
    that is a module, else ``a.b``; relative imports resolved)."""
    names: set[str] = set()
    if isinstance(node, ast.Import):
        names = {a.name for a in node.names}
    elif isinstance(node, ast.ImportFrom):
        base = node.module or ""
        if node.level:
            parts = module.split(".") if is_package else module.split(".")[:-1]
            parts = parts[:len(parts) - (node.level - 1)]
            base = ".".join(parts + ([base] if base else []))
        for a in node.names:
            sub = f"{base}.{a.name}"
            names.add(sub if sub in MODULES else base)
    out = set()
    for name in names:
        while name not in MODULES and "." in name:
            name = name.rsplit(".", 1)[0]
        if name in MODULES and name.startswith("dressmeup"):
            out.add(name)
    return out


def _import_nodes() -> list[tuple[str, Path, ast.AST, bool]]:
    """(module, path, import node, inside a function) for every import that runs."""
    out = []
    for module, path in MODULES.items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        skip = _type_checking_nodes(tree)
        in_function = set()
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                in_function |= {id(n) for n in ast.walk(node)}
        for node in ast.walk(tree):
            if isinstance(node, (ast.Import, ast.ImportFrom)) and id(node) not in skip:
                out.append((module, path, node, id(node) in in_function))
    return out


NODES = _import_nodes()


def _graph(function_level: bool = True) -> dict[str, set[str]]:
    graph: dict[str, set[str]] = {m: set() for m in MODULES}
    for module, path, node, inside in NODES:
        if inside and not function_level:
            continue
        graph[module] |= _targets(node, module, path.name == "__init__.py") - {module}
    return graph


def _imports() -> list[tuple[str, str, str]]:
    """(file, importing unit, imported unit) for every package import, at any depth."""
    out = []
    for module, path, node, _ in NODES:
        src = _unit(module)
        for target in _targets(node, module, path.name == "__init__.py"):
            dst = _unit(target)
            if dst is not None and dst != src:
                out.append((str(path.relative_to(PACKAGE.parent)), src, dst))
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


def test_the_devkit_imports_no_method():
    bad = [f"{path}: imports {dst}" for path, src, dst in _imports()
           if src == "bench" and dst in BENCH_MAY_NOT_IMPORT]
    assert not bad, "bench must not import methods or what runs them:\n" + "\n".join(bad)
    assert all(_level(u) > _level("bench") for u in BENCH_MAY_NOT_IMPORT)


def test_the_checker_sees_imports_at_every_depth():
    # guard against a checker that silently finds nothing
    found = _imports()
    assert any(src == "bench" and dst == "metrics" for _, src, dst in found)
    assert _level("metrics") < _level("bench")
    # a known import inside a function (the CLI imports its stages lazily)
    assert any(inside and module.startswith("dressmeup.cli.") for module, _, _, inside in NODES)


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


def test_the_import_graph_has_no_cycle():
    # imports inside functions count: a cycle hidden in a function is still two modules that
    # need each other
    cycle = _find_cycle(_graph(function_level=True))
    assert cycle is None, "import cycle: " + " -> ".join(cycle)


def test_the_cycle_finder_finds_a_cycle():
    assert _find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": set()}) == ["a", "b", "c", "a"]
    assert _find_cycle({"a": {"b"}, "b": set()}) is None
    graph = _graph()
    assert "dressmeup.geometry.topology" in graph["dressmeup.geometry.uv_atlas"]


def _comment_lines(source: str) -> set[int]:
    """Line numbers (1-based) that hold a comment."""
    lines = set()
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type == tokenize.COMMENT:
            lines.add(tok.start[0])
    return lines


def _import_runs(tree: ast.AST) -> list[list[ast.AST]]:
    """Runs of consecutive import statements inside functions (one statement list each)."""
    runs = []
    for fn in ast.walk(tree):
        if not isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        for node in ast.walk(fn):
            for field in ("body", "orelse", "finalbody", "handlers"):
                stmts = getattr(node, field, None)
                if not isinstance(stmts, list):
                    continue
                run: list[ast.AST] = []
                for stmt in [*stmts, None]:
                    if isinstance(stmt, (ast.Import, ast.ImportFrom)):
                        run.append(stmt)
                    elif run:
                        runs.append(run)
                        run = []
    return runs


def _unexplained_function_imports() -> list[str]:
    """Imports inside functions without a reason: a comment on one of the lines of a run of
    consecutive imports, or on the line above the run (blank lines skipped)."""
    out, seen = [], set()
    for path in MODULES.values():
        source = path.read_text(encoding="utf-8")
        tree = ast.parse(source)
        skip = _type_checking_nodes(tree)
        comments = _comment_lines(source)
        lines = source.splitlines()
        for run in _import_runs(tree):
            if id(run[0]) in seen or all(id(n) in skip for n in run):
                continue
            seen.update(id(n) for n in run)
            span = set(range(run[0].lineno, run[-1].end_lineno + 1))
            above = run[0].lineno - 1
            while above >= 1 and not lines[above - 1].strip():
                above -= 1
            if comments & span or (above in comments
                                   and lines[above - 1].strip().startswith("#")):
                continue
            out += [f"{path.relative_to(PACKAGE.parent)}:{n.lineno}: {ast.unparse(n)}"
                    for n in run]
    return out


def test_imports_inside_functions_say_why():
    missing = _unexplained_function_imports()
    assert not missing, (f"{len(missing)} imports inside functions without a '# reason' comment "
                         "(move them to module level, or say why they are lazy):\n"
                         + "\n".join(missing))


def test_the_reason_check_sees_a_bare_import():
    src = ("def f():\n    import torch\n    return torch\n\n\n"
           "def g():\n    # heavy: torch\n    import torch\n    import open3d\n")
    runs = _import_runs(ast.parse(src))
    assert [[n.lineno for n in r] for r in runs] == [[2], [8, 9]]
    assert 7 in _comment_lines(src) and 2 not in _comment_lines(src)


# ---- one door per concept -------------------------------------------------------------------
# A name is imported from the module that defines it. A module never imports a name from
# another dressmeup module only to expose it (unused inside, or listed in its ``__all__``).
# The one exception is a package's ``__init__``: it is the documented door of the names its
# own submodules define (``dressmeup.body.get_body_model``), never of another package's names.

def _used_names(tree: ast.AST) -> set[str]:
    """Names the module reads (string annotations included)."""
    names = {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)}
    for n in ast.walk(tree):
        annotations = []
        if isinstance(n, (ast.arg, ast.AnnAssign)) and n.annotation is not None:
            annotations.append(n.annotation)
        if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef)) and n.returns is not None:
            annotations.append(n.returns)
        for ann in annotations:
            for c in ast.walk(ann):
                if isinstance(c, ast.Constant) and isinstance(c.value, str):
                    try:
                        names |= {x.id for x in ast.walk(ast.parse(c.value, mode="eval"))
                                  if isinstance(x, ast.Name)}
                    except SyntaxError:
                        pass
    return names


def _dunder_all(tree: ast.Module) -> set[str]:
    out: set[str] = set()
    for node in tree.body:
        if (isinstance(node, ast.Assign) and len(node.targets) == 1
                and isinstance(node.targets[0], ast.Name) and node.targets[0].id == "__all__"):
            out |= set(ast.literal_eval(node.value))
    return out


def _reexports(source: str, module: str, is_package: bool) -> list[str]:
    """Names a module imports from another dressmeup module only to expose them."""
    tree = ast.parse(source)
    used, exported = _used_names(tree), _dunder_all(tree)
    out = []
    for node in tree.body:  # module level: imports inside functions expose nothing
        if not isinstance(node, ast.ImportFrom):
            continue
        base = node.module or ""
        if node.level:
            parts = module.split(".") if is_package else module.split(".")[:-1]
            parts = parts[:len(parts) - (node.level - 1)]
            base = ".".join(parts + ([base] if base else []))
        if base.split(".")[0] != "dressmeup":
            continue
        if is_package and (base == module or base.startswith(module + ".")):
            continue  # a package's door to its own submodules
        for a in node.names:
            bound = a.asname or a.name
            if bound in exported:
                out.append(f"{node.lineno}: {bound} (from {base}) is in __all__")
            elif bound not in used:
                out.append(f"{node.lineno}: {bound} (from {base}) is imported, never used")
    return out


def test_every_name_has_one_door():
    found = []
    for module, path in MODULES.items():
        found += [f"{path.relative_to(PACKAGE.parent)}:{line}" for line in
                  _reexports(path.read_text(encoding="utf-8"), module, path.name == "__init__.py")]
    assert not found, ("re-exported names (import each name from the module that defines it; "
                       "list moved names in CHANGELOG.md):\n" + "\n".join(found))


def test_the_door_check_sees_a_shim():
    shim = ("from dressmeup.executors import Executor, make_executor\n"
            "from dressmeup.errors import InputError\n\n"
            "__all__ = ['make_executor', 'run']\n\n\n"
            "def run(e: 'Executor'):\n    raise InputError(e)\n")
    assert _reexports(shim, "dressmeup.bench.executor", False) == [
        "1: make_executor (from dressmeup.executors) is in __all__"]
    unused = "from dressmeup.io.ply import write_ply\n"
    assert _reexports(unused, "dressmeup.io.mesh", False) == [
        "1: write_ply (from dressmeup.io.ply) is imported, never used"]
    door = "from .registration import register\n\n__all__ = ['register']\n"
    assert _reexports(door, "dressmeup.body", True) == []
    other = "from dressmeup.body.skeleton import NAMES\n\n__all__ = ['NAMES']\n"
    assert _reexports(other, "dressmeup.body.registration", True) == [
        "1: NAMES (from dressmeup.body.skeleton) is in __all__"]
