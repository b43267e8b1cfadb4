"""Generator 4's ground truth, measured: plausibility, solver figures, sensitivity and cost of
samples dressed by the defined motion (dressmeup.data.synth.generator4).

For each sample (a garment type, a design subject, a target subject and a target pose; the
default set cycles through every garment type and the generator's pose families, sitting
included):

1. **Plausibility**: share of the garment's area inside the target body (face centroids,
   winding number), self-intersecting faces (pymeshlab), ipctk's exact intersection check,
   edge strain;
2. **Solver**: frames, sub-steps, Newton iterations, unconverged frames, worst residual;
3. **Sensitivity** (``--sensitivity``): the same motion with the time step halved
   (:meth:`MotionSpec.refined`) and with the Newton tolerance divided by 10; per-vertex
   distance to the base result (median, 95th percentile);
4. **Cost**: CPU seconds of the base simulation (the load average is printed beside it).

    python benchmarks/perf/synth_g4_figures.py --samples 7 --edge 0.02 --workers 2 \\
        [--sensitivity] --out benchmarks/results/generator4/DATE

writes ``figures.json``, ``figures.md`` and ``samples.png`` (front and side of every sample:
body grey, garment coloured by its distance to the body, faces inside the body red).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

from dressmeup.data.synth.common import SUBJECTS
from dressmeup.data.synth.dynamics import DynamicsSettings
from dressmeup.data.synth.garments import sample_params
from dressmeup.data.synth.generator4 import Gen4Settings, build, dress, load_body_kit
from dressmeup.data.synth.jobs import single_threaded
from dressmeup.data.synth.motion import MotionSpec
from dressmeup.data.synth.poses import pose_axis_angle

TYPES = ("t-shirt", "skirt", "dress", "trousers", "long-sleeve", "shorts", "tank-top")
POSES = ("sitting", "arms-raised", "walking", "one-arm-up", "bent-knees", "arms-forward")
GOALS = {"inside_median": 0.0, "inside_max": 0.5, "self_int_median": 0, "self_int_max": 10,
         "unconverged": 0, "sens_median_mm": 1.0, "sens_p95_mm": 5.0, "cpu_s": 15.0}


def load() -> str:
    return f"{os.getloadavg()[0]:.1f}"


def plan(n: int, seed: int = 0) -> list[dict]:
    """``n`` samples: garment type ``k mod 7``, pose ``k mod 6``, design subject ``k mod 6``
    and target subject ``(k + 1) mod 6``."""
    out = []
    for k in range(n):
        gtype = TYPES[k % len(TYPES)]
        params = sample_params(gtype, np.random.default_rng([seed, 11, k]))
        out.append({"id": f"X{k:02d}", "type": gtype, "params": params,
                    "pose": POSES[k % len(POSES)],
                    "design": SUBJECTS[k % len(SUBJECTS)][0],
                    "target": SUBJECTS[(k + 1) % len(SUBJECTS)][0]})
    return out


def _shape(name: str) -> np.ndarray:
    return np.asarray(dict(SUBJECTS)[name], np.float64)


def run_sample(job: tuple[dict, float, bool, str]) -> dict:
    """Dress one sample (and its sensitivity variants); save its meshes under ``out``. A
    sample the simulation cannot finish is returned with its ``error``."""
    try:
        return _run_sample(*job)
    except RuntimeError as exc:
        return {**job[0], "error": str(exc), "load": load()}


def _run_sample(item: dict, edge: float, sensitivity: bool, out: str) -> dict:
    with single_threaded():
        kit = load_body_kit("anny")
        g = build(kit, item["type"], item["params"], _shape(item["design"]), edge)
        pose = pose_axis_angle(item["pose"], kit.joint_names, g.frame, rng=None)
        base_settings = Gen4Settings(edge_length=edge)
        t0 = time.process_time()
        base = dress(kit, g, _shape(item["target"]), pose, base_settings,
                     on_frame=lambda k, x, st: k % 25 or print(
                         f"  {item['id']} frame {k}: {st}", flush=True))
        res = {**item, "vertices": len(g.vertices), "stats": base.stats,
               "cpu_s": time.process_time() - t0, "load": load()}
        np.savez_compressed(Path(out) / f"{item['id']}.npz", V=base.vertices, F=g.faces,
                            body=base.body_vertices, body_F=kit.faces)
        if sensitivity:
            variants = {
                "dt_half": dataclasses.replace(base_settings,
                                               motion=base_settings.motion.refined(2)),
                "tolerance_tenth": dataclasses.replace(
                    base_settings, dynamics=dataclasses.replace(
                        base_settings.dynamics,
                        tolerance=base_settings.dynamics.tolerance / 10))}
            res["sensitivity"] = {}
            for name, st in variants.items():
                other = dress(kit, g, _shape(item["target"]), pose, st)
                d = np.sqrt(np.sum((other.vertices - base.vertices) ** 2, axis=1)) * 1000
                res["sensitivity"][name] = {"median_mm": float(np.median(d)),
                                            "p95_mm": float(np.percentile(d, 95)),
                                            "max_mm": float(d.max()),
                                            "cpu_s": other.stats["cpu_s"]}
    return res


def pictures(results: list[dict], out: Path) -> None:
    """``samples.png``: front and side of every sample."""
    # heavy: matplotlib through viz (~0.3 s to import)
    from matplotlib import colormaps

    from dressmeup.geometry.proximity import closest_points
    from dressmeup.geometry.winding import winding_number
    from dressmeup.viz.contact_sheet import MeshLayer, render_contact_sheet

    cells, titles = [], []
    cmap = colormaps["viridis"]
    for r in results:
        if "error" in r:
            continue
        m = np.load(out / f"{r['id']}.npz")
        V, F, B, BF = m["V"], m["F"], m["body"], m["body_F"]
        d, _, _ = closest_points(B, BF, V[F].mean(1))
        col = cmap(np.clip(d / 0.05, 0, 1))[:, :3]
        col[winding_number(B, BF, V[F].mean(1)) > 0.5] = (0.9, 0.1, 0.1)
        layers = [MeshLayer(B, BF, (0.72, 0.72, 0.72)), MeshLayer(V, F, face_colors=col)]
        for side in ("front", "side"):
            cells.append(layers if side == "front" else
                         [MeshLayer(L.vertices @ _turn(), L.faces, L.color, L.face_colors)
                          for L in layers])
            titles.append(f"{r['id']} {r['type']} {r['pose']} ({side})")
    render_contact_sheet(cells, out / "samples.png", right=np.array([1.0, 0, 0]),
                         up=np.array([0, 1.0, 0]), ncols=4, titles=titles,
                         suptitle="generator 4: garment coloured by distance to the body "
                                  "(0-50 mm), red: inside the body")


def _turn() -> np.ndarray:
    """Rotation (row-vector convention) of 90 degrees about the vertical (y) axis."""
    return np.array([[0.0, 0, -1], [0, 1, 0], [1, 0, 0]])


def summary(results: list[dict]) -> str:
    """Markdown table of the figures against the goals."""
    failed = [r for r in results if "error" in r]
    results = [r for r in results if "error" not in r]
    inside = [r["stats"]["inside_area_pct"] for r in results]
    selfi = [r["stats"]["self_intersecting_faces"] for r in results]
    unconv = [r["stats"]["unconverged_frames"] for r in results]
    cpu = [r["cpu_s"] for r in results]
    lines = ["| sample | type | pose | vertices | inside % | self-int | ipctk free | "
             "unconverged frames | iterations | worst residual | CPU s (load) |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        s = r["stats"]
        lines.append(f"| {r['id']} | {r['type']} | {r['pose']} | {r['vertices']} | "
                     f"{s['inside_area_pct']:.3f} | {s['self_intersecting_faces']} | "
                     f"{s['intersection_free']} | {s['unconverged_frames']} | "
                     f"{s['iterations']} | {s['worst_residual']:.2f} | "
                     f"{r['cpu_s']:.0f} ({r['load']}) |")
    lines += [f"| {r['id']} | {r['type']} | {r['pose']} | failed: {r['error']} |"
              + " |" * 7 for r in failed]
    lines += ["", "| figure | measured | goal |", "|---|---|---|",
              f"| inside area | median {np.median(inside):.3f} %, max {max(inside):.3f} % | "
              f"median {GOALS['inside_median']} %, max <= {GOALS['inside_max']} % |",
              f"| self-intersecting faces | median {np.median(selfi):.1f}, max {max(selfi)} | "
              f"median {GOALS['self_int_median']}, max <= {GOALS['self_int_max']} |",
              f"| unconverged frames | {sum(unconv)} in {len(results)} samples | 0 |",
              f"| CPU s a sample | median {np.median(cpu):.0f} | <= {GOALS['cpu_s']:.0f} |",
              f"| samples the simulation could not finish | {len(failed)} | 0 |"]
    sens = [r["sensitivity"] for r in results if "sensitivity" in r]
    for name in ("dt_half", "tolerance_tenth"):
        if sens:
            med = np.median([s[name]["median_mm"] for s in sens])
            p95 = np.median([s[name]["p95_mm"] for s in sens])
            lines.append(f"| sensitivity, {name} | median {med:.2f} mm, p95 {p95:.2f} mm "
                         f"(medians over samples) | <= {GOALS['sens_median_mm']} mm, p95 <= "
                         f"{GOALS['sens_p95_mm']} mm |")
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--samples", type=int, default=7)
    ap.add_argument("--edge", type=float, default=0.015)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--sensitivity", action="store_true")
    ap.add_argument("--out", type=Path, required=True)
    a = ap.parse_args()
    a.out.mkdir(parents=True, exist_ok=True)
    items = plan(a.samples)
    print(f"{len(items)} samples, edge {a.edge * 1000:.0f} mm, motion {MotionSpec()}, "
          f"dynamics {DynamicsSettings()}; load {load()}", flush=True)
    jobs = [(it, a.edge, a.sensitivity, str(a.out)) for it in items]
    t0 = time.time()
    results = []
    with ProcessPoolExecutor(a.workers) as pool:
        for fut in as_completed([pool.submit(run_sample, job) for job in jobs]):
            r = fut.result()
            results.append(r)
            (a.out / f"{r['id']}.json").write_text(json.dumps(r, indent=1, default=float))
            if "error" in r:
                print(f"{r['id']} {r['type']:12s} {r['pose']:12s} FAILED: {r['error']}",
                      flush=True)
                continue
            s = r["stats"]
            print(f"{r['id']} {r['type']:12s} {r['pose']:12s} inside {s['inside_area_pct']:.3f} % "
                  f"self-int {s['self_intersecting_faces']} unconverged "
                  f"{s['unconverged_frames']} CPU {r['cpu_s']:.0f} s (load {r['load']})",
                  flush=True)
    results.sort(key=lambda r: r["id"])
    (a.out / "figures.json").write_text(json.dumps(
        {"results": results, "wall_s": time.time() - t0, "goals": GOALS}, indent=1,
        default=float))
    table = summary(results)
    (a.out / "figures.md").write_text(table)
    print(table)
    pictures(results, a.out)


if __name__ == "__main__":
    main()
