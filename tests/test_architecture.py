"""The import arrows of docs/architecture.md point one way: a stage imports only stages below it.

Parses every module of the package (no import is executed) and checks every ``dressmeup.*``
import, at module level and inside functions, against the layer table below; the whole
import graph (function-level imports included) must have no cycle; and an import inside a
function must say in a comment why it is not at module level, in a fixed vocabulary that is
checked (``heavy:``, ``optional:``, ``start-up:``; see REASONS); and a name is imported from
the module that defines it (no re-export shims).
"""

from __future__ import annotations

import ast
import io
import re
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


def _comment_lines(source: str) -> dict[int, str]:
    """The comment of each line that holds one (1-based line number -> text after '#')."""
    lines = {}
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type == tokenize.COMMENT:
            lines[tok.start[0]] = tok.string.lstrip("#").strip()
    return lines


def _import_runs(tree: ast.AST) -> list[tuple[list[ast.AST], bool]]:
    """Runs of consecutive import statements inside functions (one statement list each), each
    with whether it is the body of a ``try`` that handles ``ImportError``."""
    runs = []
    for fn in ast.walk(tree):
        if not isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        for node in ast.walk(fn):
            for field in ("body", "orelse", "finalbody", "handlers"):
                stmts = getattr(node, field, None)
                if not isinstance(stmts, list):
                    continue
                handled = field == "body" and isinstance(node, ast.Try) and any(
                    h.type is not None and {"ImportError", "ModuleNotFoundError", "Exception"}
                    & {n.id for n in ast.walk(h.type) if isinstance(n, ast.Name)}
                    for h in node.handlers)
                run: list[ast.AST] = []
                for stmt in [*stmts, None]:
                    if isinstance(stmt, (ast.Import, ast.ImportFrom)):
                        run.append(stmt)
                    elif run:
                        runs.append((run, handled))
                        run = []
    return runs


# ---- why an import is inside a function -----------------------------------------------------
# The comment on the run of imports (or the line above it) starts with one of these reasons;
# anything else (a cycle, a habit) is not a reason: the import goes to module level.
#   heavy: LIB[, LIB...]  each import loads LIB (itself, or a dressmeup module that imports
#                         it at module level), LIB is in IMPORT_MS at HEAVY_MS or more, and
#                         the importing module has not loaded LIB already
#   optional: LIB         LIB is not a required dependency in pyproject.toml and the import
#                         sits in a ``try`` that handles ImportError
#   start-up: ...         only in ``dressmeup/cli/``: a stage loads when its command runs
REASONS = ("heavy", "optional", "start-up")
HEAVY_MS = 100
# Import time in ms of each library a function imports lazily, numpy already imported:
# ``python -X importtime -c "import numpy; import LIB"`` (benchmarks/perf/import_times.py
# measures and prints this table; 2-core CPU machine, the fastest of two runs).
IMPORT_MS = {
    "alembic": 619, "anny": 4965, "cv2": 53, "ctypes": 0, "dask": 223, "distributed": 312,
    "fastapi": 652, "hashlib": 5, "igl": 337, "ipctk": 169, "jsonschema": 80, "matplotlib": 111,
    "matplotlib.collections": 245, "matplotlib.pyplot": 527,
    "mpl_toolkits.mplot3d": 328, "open3d": 1925, "pandas": 521, "PIL": 9,
    "potpourri3d": 333, "pyarrow": 62, "pyarrow.parquet": 99, "pykdtree": 1, "pymeshlab": 174,
    "rich": 1, "robust_laplacian": 3, "scipy": 13, "scipy.interpolate": 680, "scipy.io": 303,
    "scipy.linalg": 316, "scipy.optimize": 1113, "scipy.sparse": 277, "scipy.special": 234, "scipy.spatial": 310,
    "sqlalchemy": 362, "torch": 2324, "tqdm": 24, "trimesh": 1157, "uvicorn": 119,
    "warp": 462, "xatlas": 1,
}
# distribution name -> import name, where they differ
DIST_MODULES = {"opencv-python-headless": "cv2", "libigl": "igl", "open3d-cpu": "open3d",
                "robust-laplacian": "robust_laplacian", "Pillow": "PIL"}


def _required_modules() -> set[str]:
    """Import names of the required dependencies (``[project] dependencies`` of pyproject.toml;
    read without tomllib, which Python 3.10 lacks)."""
    text = (PACKAGE.parent / "pyproject.toml").read_text(encoding="utf-8")
    block = re.search(r"^dependencies = \[(.*?)^\]", text, re.S | re.M).group(1)
    out = set()
    for dep in re.findall(r'^\s*"([^"]+)"', block, re.M):
        dist = re.match(r"[A-Za-z0-9_.\-]+", dep).group(0)
        out.add(DIST_MODULES.get(dist, dist.lower().replace("-", "_")))
    return out


def _external_names(node: ast.AST) -> set[str]:
    """Dotted names of the non-dressmeup modules an import statement may load."""
    if isinstance(node, ast.Import):
        return {a.name for a in node.names if a.name.split(".")[0] != "dressmeup"}
    if node.level or (node.module or "").split(".")[0] == "dressmeup":
        return set()
    return {node.module} | {f"{node.module}.{a.name}" for a in node.names}


def _loaded_at_import() -> dict[str, set[str]]:
    """Per module, every non-dressmeup module name its import loads through module-level
    imports (its own, its packages' and those of the dressmeup modules it imports)."""
    own: dict[str, set[str]] = {m: set() for m in MODULES}
    for module, _, node, inside in NODES:
        if not inside:
            own[module] |= _external_names(node)
    graph = _graph(function_level=False)
    for module in MODULES:  # importing a module runs its packages' __init__ first
        parts = module.split(".")
        graph[module] |= {".".join(parts[:i]) for i in range(1, len(parts))} & MODULES.keys()
    memo: dict[str, set[str]] = {}

    def closure(module: str, stack: frozenset = frozenset()) -> set[str]:
        if module in memo:
            return memo[module]
        out = set(own[module])
        for dep in graph[module] - stack - {module}:
            out |= closure(dep, stack | {module})
        if not stack:
            memo[module] = out
        return out

    return {m: closure(m) for m in MODULES}


def _loads(names: set[str], lib: str) -> bool:
    return any(n == lib or n.startswith(lib + ".") for n in names)


def _reason_problems(module: str, path: Path, run: list[ast.AST], handled: bool,
                     reason: str | None, loaded: dict[str, set[str]],
                     required: set[str]) -> list[str]:
    """What is wrong with the reason given for one run of imports inside a function."""
    kind, _, rest = (reason or "").partition(":")
    if kind not in REASONS or not rest.strip():
        return [f"reason {reason!r} is not one of {', '.join(r + ':' for r in REASONS)}"]
    rest = rest.strip()
    is_package = path.name == "__init__.py"
    internal = [t for n in run for t in _targets(n, module, is_package)]
    external = [n for n in run if _external_names(n)]
    if kind == "start-up":
        if not module.startswith("dressmeup.cli"):
            return ["start-up: is a reason only in dressmeup/cli/"]
        return []
    if kind == "optional":
        problems = []
        if internal:
            problems.append("optional: a dressmeup module is never optional")
        for n in external:
            top = min(_external_names(n)).split(".")[0]
            if top in required:
                problems.append(f"optional: {top} is a required dependency (pyproject.toml)")
        if not handled:
            problems.append("optional: the import is not in a try that handles ImportError")
        return problems
    libs = []
    for word in rest.split(","):
        word = word.strip().split(" ")[0].rstrip(";.:)")
        if not word:
            break
        libs.append(word)
        if " " in rest.split(",")[len(libs) - 1].strip():
            break  # the free text after the list of libraries
    problems = [f"heavy: {lib} takes {IMPORT_MS[lib]} ms to import (heavy is {HEAVY_MS} ms "
                "or more)" if lib in IMPORT_MS else f"heavy: {lib} is not in IMPORT_MS"
                for lib in libs if IMPORT_MS.get(lib, 0) < HEAVY_MS]
    for lib in libs:
        if _loads(loaded[module], lib):
            problems.append(f"heavy: {module} has loaded {lib} already (module level)")
    for n in external:
        if not any(_loads({name}, lib) for name in _external_names(n) for lib in libs):
            problems.append(f"heavy: {ast.unparse(n)} loads none of {', '.join(libs)}")
    for target in internal:
        if not any(_loads(loaded[target], lib) for lib in libs):
            problems.append(f"heavy: {target} loads none of {', '.join(libs)} at import")
    return problems


def _function_import_problems() -> list[str]:
    """Every run of imports inside a function whose reason is missing or does not hold: a
    comment on one of the lines of the run, or on the line above it (blank lines skipped)."""
    out = []
    loaded, required = _loaded_at_import(), _required_modules()
    for module, path in MODULES.items():
        source = path.read_text(encoding="utf-8")
        tree = ast.parse(source)
        skip = _type_checking_nodes(tree)
        comments = _comment_lines(source)
        lines = source.splitlines()
        used: set[int] = set()
        seen: set[int] = set()  # ids of this tree's nodes (a freed tree's ids are reused)
        for run, handled in _import_runs(tree):
            if id(run[0]) in seen or all(id(n) in skip for n in run):
                continue
            seen.update(id(n) for n in run)
            above = run[0].lineno - 1
            while above >= 1 and not lines[above - 1].strip():
                above -= 1
            on = [comments[i] for i in range(run[0].lineno, run[-1].end_lineno + 1)
                  if i in comments]
            reason = on[0] if on else (comments.get(above) if lines[above - 1].strip()
                                       .startswith("#") else None)
            used.update(i for i in [*range(run[0].lineno, run[-1].end_lineno + 1), above]
                        if comments.get(i) == reason)
            where = f"{path.relative_to(PACKAGE.parent)}:{run[0].lineno}"
            out += [f"{where}: {p}" for p in
                    _reason_problems(module, path, run, handled, reason, loaded, required)]
        out += [f"{path.relative_to(PACKAGE.parent)}:{i}: the reason {text!r} is on no import "
                "inside a function" for i, text in sorted(comments.items())
                if i not in used and text.partition(":")[0] in REASONS]
    return out


# Modules whose reasons predate the vocabulary, with the most problems each may still have
# (the numbers only go down).
OLD_REASONS: dict[str, int] = {}


def test_imports_inside_functions_say_why():
    problems = _function_import_problems()
    per_file: dict[str, list[str]] = {}
    for p in problems:
        per_file.setdefault(p.split(":", 1)[0], []).append(p)
    problems = [p for f, ps in per_file.items() if len(ps) > OLD_REASONS.get(f, 0) for p in ps]
    assert not problems, (f"{len(problems)} imports inside functions without a reason that "
                          "holds (move them to module level, or give one of "
                          f"{', '.join(r + ':' for r in REASONS)}):\n" + "\n".join(problems))


def test_the_reason_check_sees_a_bare_import():
    src = ("def f():\n    import torch\n    return torch\n\n\n"
           "def g():\n    # heavy: torch\n    import torch\n    import open3d\n\n\n"
           "def h():\n    try:\n        import pyk4a\n    except ImportError:\n        pass\n")
    runs = _import_runs(ast.parse(src))
    assert [([n.lineno for n in r], handled) for r, handled in runs] == [
        ([2], False), ([8, 9], False), ([14], True)]
    assert 7 in _comment_lines(src) and 2 not in _comment_lines(src)


def test_the_reason_check_holds_each_reason_to_its_rule():
    path = PACKAGE / "x.py"
    loaded = {"dressmeup.x": {"numpy", "scipy.sparse"}, "dressmeup.y": {"torch"}}

    def problems(src, reason, module="dressmeup.x"):
        (run, handled), = _import_runs(ast.parse(src))
        return _reason_problems(module, path, run, handled, reason, loaded, {"numpy", "torch"})

    lazy = "def f():\n    import torch\n    import open3d\n"
    assert problems(lazy, "heavy: torch, open3d (the network)") == []
    assert problems(lazy, "heavy: torch") == ["heavy: import open3d loads none of torch"]
    assert problems(lazy, "cycle: x imports y") != []
    assert problems(lazy, None) != []
    assert problems("def f():\n    import cv2\n", "heavy: cv2") == [
        f"heavy: cv2 takes {IMPORT_MS['cv2']} ms to import (heavy is {HEAVY_MS} ms or more)"]
    assert problems("def f():\n    import scipy.sparse\n", "heavy: scipy.sparse") == [
        "heavy: dressmeup.x has loaded scipy.sparse already (module level)"]
    assert problems("def f():\n    import torch\n", "start-up: the stage loads later") == [
        "start-up: is a reason only in dressmeup/cli/"]
    assert problems("def f():\n    import torch\n", "start-up: the stage",
                    module="dressmeup.cli.x") == []
    optional = "def f():\n    try:\n        import {}\n    except ImportError:\n        pass\n"
    assert problems(optional.format("pyk4a"), "optional: pyk4a") == []
    assert problems(optional.format("torch"), "optional: torch") == [
        "optional: torch is a required dependency (pyproject.toml)"]
    assert problems("def f():\n    import pyk4a\n", "optional: pyk4a") == [
        "optional: the import is not in a try that handles ImportError"]


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
