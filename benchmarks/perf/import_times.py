"""Import time of each library the package imports inside functions, numpy already imported.

``tests/test_architecture.py`` accepts ``# heavy: LIB`` as the reason for an import inside a
function only when LIB takes ``HEAVY_MS`` (100 ms) or more to import, by its table
``IMPORT_MS``. This script measures the libraries of that table (or those named) with
``python -X importtime -c "import numpy; import LIB"`` in fresh interpreters, the fastest of
``--repeat`` runs, and prints the table to paste there.

    python benchmarks/perf/import_times.py                   # every library of IMPORT_MS
    python benchmarks/perf/import_times.py torch scipy.sparse --repeat 3
"""

from __future__ import annotations

import argparse
import ast
import re
import subprocess
import sys
from pathlib import Path

LINE = re.compile(r"import time:\s+\d+ \|\s+(\d+) \|( *)(\S+)")


def table_libraries() -> list[str]:
    """The keys of ``IMPORT_MS`` in tests/test_architecture.py."""
    tree = ast.parse((Path(__file__).resolve().parents[2] / "tests" / "test_architecture.py")
                     .read_text(encoding="utf-8"))
    for node in tree.body:
        if isinstance(node, ast.Assign) and getattr(node.targets[0], "id", "") == "IMPORT_MS":
            return sorted(ast.literal_eval(node.value))
    raise SystemExit("IMPORT_MS not found in tests/test_architecture.py")


def import_ms(lib: str) -> float | None:
    """Milliseconds to import ``lib`` after numpy (None when it does not import)."""
    r = subprocess.run([sys.executable, "-X", "importtime", "-c", f"import numpy; import {lib}"],
                       capture_output=True, text=True, cwd=Path.home())
    if r.returncode:
        return None
    total, after_numpy = 0, False
    for line in r.stderr.splitlines():
        m = LINE.match(line)
        if not m or m.group(2) != " ":  # top-level imports only
            continue
        if m.group(3) == "numpy":
            after_numpy = True
        elif after_numpy:
            total += int(m.group(1))
    return total / 1000


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("libs", nargs="*", help="libraries to measure (default: IMPORT_MS's)")
    ap.add_argument("--repeat", type=int, default=2)
    args = ap.parse_args()
    rows = {}
    for lib in args.libs or table_libraries():
        runs = [import_ms(lib) for _ in range(args.repeat)]
        rows[lib] = None if None in runs else round(min(runs))
        print(f"{lib:28s} {rows[lib]} ms", file=sys.stderr)
    print("IMPORT_MS = {")
    print("\n".join(f"    {lib!r}: {ms}," for lib, ms in rows.items() if ms is not None))
    print("}")


if __name__ == "__main__":
    main()
