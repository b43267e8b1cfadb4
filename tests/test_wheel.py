"""The real install: a wheel built from the source tree carries every shipped file and runs
the isomap-refine baseline with its shipped weights (CI installs with ``-e``, which would not
notice a missing package-data pattern)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import textwrap
import zipfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

RUN_REFINE = textwrap.dedent("""
    import json, sys
    import numpy as np
    import dressmeup
    from dressmeup.body import get_body_model
    from dressmeup.methods.retarget import get_method
    from dressmeup.methods.retarget.base import body_context

    model = get_body_model("anny")
    src = model.default_params()
    tgt = src.copy()
    tgt.pose[0] = [0.0, 0.4, 0.0]
    ctx = body_context(model, src)
    y = ctx.vertices[:, 1]
    sel = (y > np.percentile(y, 55)) & (y < np.percentile(y, 70))   # a band of the torso
    F_all = np.asarray(model.faces)
    idx = np.flatnonzero(sel)
    remap = -np.ones(model.n_vertices, np.int64)
    remap[idx] = np.arange(len(idx))
    F = remap[F_all[sel[F_all].all(1)]]
    V = ctx.vertices[idx] + 0.01 * ctx.skin_normals()[idx]
    method = get_method("isomap-refine")
    out = method.retarget(V, F, src, tgt, model)
    print(json.dumps({"module": dressmeup.__file__, "shape": list(out.shape),
                      "finite": bool(np.isfinite(out).all()),
                      "moved_mm": float(np.linalg.norm(out - V, axis=1).mean() * 1000),
                      "body_model": method.body_model_name_}))
""")


def _source_files() -> list[str]:
    listed = subprocess.run(["git", "ls-files", "-co", "--exclude-standard", "dressmeup",
                             "pyproject.toml", "README.md", "LICENSE"], cwd=REPO,
                            capture_output=True, text=True, check=True).stdout.split("\n")
    return [f for f in listed if f and (REPO / f).is_file()]


def test_wheel_carries_every_shipped_file_and_runs_isomap_refine(tmp_path):
    src = tmp_path / "src"
    files = _source_files()
    for f in files:
        (src / f).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(REPO / f, src / f)
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation",
                    "-q", "-w", str(tmp_path / "dist"), str(src)], check=True,
                   capture_output=True)
    wheel = next((tmp_path / "dist").glob("dressmeup-*.whl"))
    names = set(zipfile.ZipFile(wheel).namelist())
    shipped = [f for f in files if f.startswith("dressmeup/") and not f.endswith(".py")]
    assert any(f.endswith(".pt") for f in shipped)
    missing = [f for f in shipped if f not in names]
    assert not missing, f"not in the wheel (add to [tool.setuptools.package-data]): {missing}"

    site = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "--no-compile", "-q",
                    "--target", str(site), str(wheel)], check=True, capture_output=True)
    env = {**os.environ, "PYTHONPATH": str(site), "DRESSMEUP_NO_PROGRESS": "1"}
    proc = subprocess.run([sys.executable, "-c", RUN_REFINE], cwd=tmp_path, env=env,
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr[-3000:]
    res = json.loads(proc.stdout.strip().splitlines()[-1])
    assert res["module"].startswith(str(site)), res
    assert res["finite"] and res["shape"][1] == 3 and res["body_model"] == "anny"
    assert 1.0 < res["moved_mm"] < 500.0, res
