"""Page speed of the report site: time to load a method page with 250 items in headless
Chromium, beside a 30-item page measured in the same run.

Builds a dataset of small tube garments on the procedural body (125 garments x 2 poses:
every ordered pair of poses of a garment is an item, 250 items; 15 garments: 30 items), scores a ground-truth + 2 mm noise
submission (2,000 surface samples per mesh), writes the report site (5 best + 5 worst
pictures) and opens the method page in headless Chromium (Debian's chromium +
chromium-driver via selenium, as the browser tests). Prints, with the load average beside
every figure: site writing time, page size, and per page the median over repeats of
navigation -> load event, and of a click-sort of the P2S column.

    python benchmarks/perf/report.py                 # 250 items vs 30 items, 5 loads each
    python benchmarks/perf/report.py --repeats 10
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]


def _browser_helpers():
    spec = importlib.util.spec_from_file_location("site_browser",
                                                  REPO / "tests" / "viz" / "browser.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def tube(radius, y0, y1, nu, nv):
    u = np.linspace(0, 2 * np.pi, nu, endpoint=False)
    v = np.linspace(y0, y1, nv)
    uu, vv = np.meshgrid(u, v)
    V = np.stack([radius * np.cos(uu), vv, radius * np.sin(uu)], -1).reshape(-1, 3)
    j, i = np.meshgrid(np.arange(nv - 1), np.arange(nu), indexing="ij")
    a = (j * nu + i).ravel()
    b = (j * nu + (i + 1) % nu).ravel()
    c, d = a + nu, b + nu
    F = np.concatenate([np.stack([a, c, b], 1), np.stack([b, c, d], 1)])
    return V, F.astype(np.int64)


def build(root: Path, garments: int, poses: int) -> Path:
    from dressmeup.body import get_body_model
    from dressmeup.data.writer import DatasetWriter

    model = get_body_model("procedural")
    gen = {"name": "perf-report", "version": "1",
           "params": {"garments": garments, "poses": poses}, "seed": 0}
    w = DatasetWriter(root, {"name": "perf-report", "version": "1", "body_model": "procedural",
                             "generator": gen})
    cats = ("topwear", "bottomwear", "dress")
    for g in range(garments):
        V, F = tube(0.16 + 0.01 * g, 0.7, 1.35, 24, 10)
        for p in range(poses):
            params = model.default_params()
            params.pose[16, 2] = -0.2 * p
            rng = np.random.default_rng(100 * g + p)
            Vp = V + 0.004 * p * np.sin(V[:, [1, 2, 0]] * 5 + rng.uniform(0, 6, 3))
            w.add_sample(subject_id="S01", garment_id=f"G{g:02d}", pose_id=f"P{p}",
                         category=cats[g % 3], garment_type=cats[g % 3], split="test",
                         garment=(Vp, F), body=params)
    w.finalize()
    return root


def make_result(base: Path, garments: int, poses: int) -> tuple[Path, int]:
    import json

    from dressmeup.bench import load_edition, score_submission, write_submission
    from dressmeup.data import Dataset

    data = build(base / "data", garments, poses)
    ed_path = base / "edition.json"
    ed_path.write_text(json.dumps({
        "name": "perf-report-v1", "version": 1, "task": "retarget",
        "dataset": {"kind": "generated", "generator": "perf-report", "generator_version": "1",
                    "params": {"garments": garments, "poses": poses}, "seed": 0},
        "split": "test", "metrics": ["p2s", "ed", "nc", "ir"],
        "options": {"n_samples": 2000, "seed": 0}, "primary_metric": "p2s"}))
    ed = load_edition(ed_path)
    rng = np.random.default_rng(0)
    preds = {p.pair_id: p.target.garment().vertices + rng.normal(0, 0.002, (1, 3))
             for p in Dataset(data).retarget_pairs("test")}
    sub = write_submission(base / "sub", preds, edition=ed, method="GT+2mm")
    res = score_submission(sub, ed, data, base / "res", show_progress=False)
    return res.path, len(preds)


def measure(url: str, repeats: int, drv) -> tuple[float, float]:
    """Median load time (navigation start -> load event end) and median sort-click time."""
    from selenium.webdriver.common.by import By

    loads, sorts = [], []
    for _ in range(repeats):
        drv.get("about:blank")
        drv.get(url)
        t = drv.execute_script("const n = performance.getEntriesByType('navigation')[0];"
                               "return n.loadEventEnd - n.startTime;")
        loads.append(float(t) / 1000.0)
        th = drv.find_elements(By.CSS_SELECTOR, "table.items thead th")
        col = next(h for h in th if h.text.startswith("P2S"))
        t0 = time.perf_counter()
        col.click()
        drv.execute_script("return document.querySelector('table.items tbody tr').textContent")
        sorts.append(time.perf_counter() - t0)
    return statistics.median(loads), statistics.median(sorts)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    os.environ.setdefault("DRESSMEUP_NO_PROGRESS", "1")
    browser = _browser_helpers()
    _, _, why = browser.chromium_paths()
    if why:
        raise SystemExit(f"cannot measure: {why}")
    from dressmeup.viz.site import write_site

    rows = []
    with tempfile.TemporaryDirectory() as tmp, browser.chromium() as drv:
        for garments, poses in ((125, 2), (15, 2)):   # 250 and 30 pairs
            base = Path(tmp) / f"g{garments}p{poses}"
            base.mkdir()
            res, n = make_result(base, garments, poses)
            t0 = time.perf_counter()
            site = write_site([res], base / "site")
            t_site = time.perf_counter() - t0
            load_site = os.getloadavg()[0]
            page = site.method_pages[0]
            size = sum(p.stat().st_size for p in page.parent.rglob("*") if p.is_file())
            load, sort = measure(page.resolve().as_uri(), args.repeats, drv)
            rows.append((n, t_site, load_site, page.stat().st_size, size, load, sort,
                         os.getloadavg()[0]))
    print(f"{'items':>6} {'site s':>7} {'(load)':>6} {'page kB':>8} {'+img kB':>8} "
          f"{'load s':>7} {'sort s':>7} {'(load)':>6}")
    for n, ts, la, ps, size, load, sort, lb in rows:
        print(f"{n:6d} {ts:7.1f} {la:6.2f} {ps / 1024:8.0f} {size / 1024:8.0f} {load:7.3f} "
              f"{sort:7.3f} {lb:6.2f}")
    big, small = rows[0], rows[1]
    print(f"ratio {big[0]}-item / {small[0]}-item page: load x{big[5] / small[5]:.2f}, "
          f"sort x{big[6] / small[6]:.2f} (same run, same browser)")


if __name__ == "__main__":
    main()
