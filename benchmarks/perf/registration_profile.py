"""cProfile of one registration fit on a scan of the perf suite (where a fit's time goes).

Builds the scan of ``KIND-POSE`` (subject 0) exactly as ``registration.py`` does, fits it
with the default registrar (or the settings ``OPTIONS``, JSON) under cProfile, torch on one
thread, and writes the fit's CPU seconds (profiler overhead included), its vertex error
(mm), the load average, and the top functions by cumulative and by own time to ``OUT``.

    python benchmarks/perf/registration_profile.py clothed t-pose /tmp/profile.txt
    python benchmarks/perf/registration_profile.py clothed t-pose /tmp/p.txt '{"n_body_points": 3000}'
"""

from __future__ import annotations

import cProfile
import io
import json
import os
import pstats
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))


def main(argv: list[str]) -> int:
    if len(argv) not in (3, 4):
        raise SystemExit(__doc__)
    kind, pose, out = argv[:3]
    options = json.loads(argv[3]) if len(argv) == 4 else {}
    os.environ.setdefault("DRESSMEUP_NO_PROGRESS", "1")
    import numpy as np
    import torch

    torch.set_num_threads(1)
    import registration as suite

    from dressmeup.body import get_body_model
    from dressmeup.body.registration import register
    from dressmeup.body.synthetic import synthetic_scan

    model = get_body_model("anny")
    seed = suite.scenario_seed(kind, pose, "", 0)
    truth = suite.make_truth(model, pose, "", np.random.default_rng(seed))
    scan = synthetic_scan(model, truth, n_points=30000, noise=0.002, n_holes=4,
                          hole_radius=0.06, seed=seed,
                          shell=(0.01, 0.03) if kind == "clothed" else None)
    profile = cProfile.Profile()
    cpu = time.process_time()
    profile.enable()
    res = register(scan, model, seed=seed, return_result=True, verbose=False, **options)
    profile.disable()
    cpu = time.process_time() - cpu
    error = 1000 * np.linalg.norm(model.posed(res.params).vertices
                                  - model.posed(truth).vertices, axis=1).mean()
    text = io.StringIO()
    print(f"fit {kind}-{pose} {options}: cpu {cpu:.1f} s (profiled), vertex {error:.2f} mm, "
          f"load {os.getloadavg()[0]:.1f}", file=text)
    stats = pstats.Stats(profile, stream=text)
    stats.sort_stats("cumulative").print_stats(45)
    stats.sort_stats("tottime").print_stats(30)
    Path(out).write_text(text.getvalue(), encoding="utf-8")
    print(text.getvalue().splitlines()[0])
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
