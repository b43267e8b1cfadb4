"""Registration cost and accuracy of two versions of the toolkit, side by side in one run.

Fits every scan of a registration edition (default ``synth-registration-v3``, 24 clothed
scans) with the default registrar of this source tree (or the settings ``--options``) and
of a baseline source tree (its default; an earlier commit, e.g. ``git archive <commit> |
tar -x -C /tmp/base``), alternating which
goes first scan by scan, so both see the same machine load. Each fit runs in a fresh
Python process importing its own tree (two versions of one package cannot share a
process) and calls the edition runner's own job, ``dressmeup.runs.registration.RegisterJob``
(``dressmeup.bench.runs`` in older trees), which reports the CPU seconds of the fit alone
(not the imports or the model build).

Per scan: CPU seconds of each version and their ratio, whether the fitted parameters are
equal bit for bit, and V2V (mean vertex distance to the true body, mm, as the edition
scores it) of each; then the means, with the load average beside every figure (figures
taken at a load above the machine's cores are not valid for speed claims).

    python benchmarks/perf/registration_speed.py --baseline /tmp/base --data DATA_ROOT
    python benchmarks/perf/registration_speed.py --baseline /tmp/base --data DATA_ROOT \\
        --items 6 --json /tmp/speed.json --keep /tmp/fits
    python benchmarks/perf/registration_speed.py --baseline /tmp/base --data DATA_ROOT \
        --options '{"n_body_points": 3000}'

``DATA_ROOT``: the edition's generated data (``benchmarks/run_baselines.py`` makes it under
``<work>/data/<edition>``).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parents[2]  # this source tree

#: what each child process runs: one default fit through the edition runner's job
CHILD = """
import json
import sys
import numpy as np
import dressmeup
try:
    from dressmeup.runs.registration import RegisterJob
except ImportError:  # a tree from before the runners left dressmeup.bench
    from dressmeup.bench.runs import RegisterJob
data, item, out, options = sys.argv[1:5]
arrays, cpu = RegisterJob(data, {"verbose": False, **json.loads(options)})(item)
np.savez(out, cpu_s=np.float64(cpu), source=np.array(dressmeup.__file__), **arrays)
"""


def fit(tree: Path, data: Path, item: str, out: Path, options: str = "{}") -> dict:
    """Fit ``item`` with the toolkit of source tree ``tree`` in a child process (registrar
    settings ``options``, JSON); its arrays (shape, pose, transl, scale, ...) and
    ``cpu_s``."""
    import numpy as np

    env = {**os.environ, "PYTHONPATH": str(tree), "DRESSMEUP_NO_PROGRESS": "1"}
    # run in the tree: ``python -c`` puts the working folder first on the import path
    subprocess.run([sys.executable, "-c", CHILD, str(data), item, str(out), options], env=env,
                   cwd=tree, check=True)
    with np.load(out) as z:
        arrays = {k: z[k] for k in z.files}
    if not str(arrays["source"]).startswith(str(tree)):  # the other tree's package was used
        raise SystemExit(f"a fit meant for {tree} imported {arrays['source']}")
    return arrays


def v2v_mm(data: Path, item: str, arrays: dict) -> float:
    """Mean vertex distance (mm) of the fitted body to the sample's true body."""
    import numpy as np

    from dressmeup.bench.tasks.common import open_dataset
    from dressmeup.body import BodyParams, get_body_model

    truth = open_dataset(data)[item].body()
    model = get_body_model(truth.model)
    fitted = BodyParams(model=truth.model, shape=arrays["shape"], pose=arrays["pose"],
                        transl=arrays["transl"], scale=float(arrays["scale"]))
    return 1000 * float(np.linalg.norm(model.posed(fitted).vertices
                                       - model.posed(truth).vertices, axis=1).mean())


def main(argv: list[str] | None = None) -> int:
    import numpy as np

    from dressmeup.bench import load_edition
    from dressmeup.bench.tasks.registration.data import items

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--baseline", required=True, help="source tree of the version to compare "
                    "with (a folder holding its dressmeup package)")
    ap.add_argument("--data", required=True, help="the edition's generated data folder")
    ap.add_argument("--edition", default="synth-registration-v3")
    ap.add_argument("--items", type=int, default=0, help="only the first N scans (0: all)")
    ap.add_argument("--options", default="{}", help="registrar settings of this tree's "
                    "fits as JSON, e.g. '{\"n_body_points\": 3000}' (the baseline's: its default)")
    ap.add_argument("--json", help="also write the rows to this JSON file")
    ap.add_argument("--keep", help="keep each fit's arrays in this folder as "
                    "<version>/<scan>.npz")
    args = ap.parse_args(argv)
    base, data = Path(args.baseline).resolve(), Path(args.data).resolve()
    if not (base / "dressmeup" / "__init__.py").is_file():
        raise SystemExit(f"--baseline {base}: no dressmeup package there")
    ids = [it.item_id for it in items(load_edition(args.edition), data)]
    ids = ids[:args.items] if args.items else ids
    trees = {"baseline": base, "this": HERE}
    print(f"{'scan':<14}{'baseline s':>11}{'this s':>8}{'ratio':>7}{'equal':>7}"
          f"{'V2V base':>10}{'V2V this':>10}{'load':>6}")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for k, item in enumerate(ids):
            order = ("baseline", "this") if k % 2 == 0 else ("this", "baseline")
            res = {name: fit(trees[name], data, item, Path(tmp) / f"{name}.npz",
                             args.options if name == "this" else "{}")
                   for name in order}
            if args.keep:
                for name, arrays in res.items():
                    (Path(args.keep) / name).mkdir(parents=True, exist_ok=True)
                    np.savez(Path(args.keep) / name / f"{item}.npz", **arrays)
            equal = all(np.array_equal(res["baseline"][key], res["this"][key])
                        for key in ("shape", "pose", "transl", "scale"))
            row = {"item": item, "load": os.getloadavg()[0], "equal": equal,
                   **{f"cpu_s_{n}": float(r["cpu_s"]) for n, r in res.items()},
                   **{f"v2v_mm_{n}": v2v_mm(data, item, r) for n, r in res.items()}}
            rows.append(row)
            print(f"{item:<14}{row['cpu_s_baseline']:11.1f}{row['cpu_s_this']:8.1f}"
                  f"{row['cpu_s_this'] / row['cpu_s_baseline']:7.2f}{str(equal):>7}"
                  f"{row['v2v_mm_baseline']:10.2f}{row['v2v_mm_this']:10.2f}"
                  f"{row['load']:6.1f}", flush=True)
    mean = {k: float(np.mean([r[k] for r in rows])) for k in
            ("cpu_s_baseline", "cpu_s_this", "v2v_mm_baseline", "v2v_mm_this", "load")}
    print(f"{'mean':<14}{mean['cpu_s_baseline']:11.1f}{mean['cpu_s_this']:8.1f}"
          f"{mean['cpu_s_this'] / mean['cpu_s_baseline']:7.2f}"
          f"{sum(r['equal'] for r in rows):>4}/{len(rows):<2}"
          f"{mean['v2v_mm_baseline']:10.2f}{mean['v2v_mm_this']:10.2f}{mean['load']:6.1f}")
    print(f"(CPU seconds of one default fit, mean of {len(rows)} scans; {os.cpu_count()} "
          "cores)")
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1), encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
