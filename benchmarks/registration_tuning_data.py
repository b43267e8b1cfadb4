"""A private tuning set for clothed registration, made like synth-registration-v3.

synth-registration-v3 is test data: no registrar default may be chosen on it. This script
makes a dataset with the same generator and options (generator 2.1.0, ``wear="rotate"``,
``scan_body="uncovered"``: one garment per scan, the skin under the garment not in the scan)
but in tuning poses of the generator set (``pose_set="generator"``: its first three poses
are sitting, arms-raised and walking, all in ``benchmarks/perf/registration.py``'s
``TUNING_POSES``), on other garments (seed 1: the edition uses seed 0) and, by default, all
six subject shapes. Not published; fit it with ``benchmarks/run_baselines.py``-like code
or ``--fit`` here.

    python benchmarks/registration_tuning_data.py /tmp/regtune            # 18 scans, ~2 CPU-min
    python benchmarks/registration_tuning_data.py /tmp/regbend --pose-set registration-tuning \
        --poses 2                                                          # 12 bent scans
    python benchmarks/registration_tuning_data.py /tmp/regtune --fit OUT.json \
        --options '{"cloth_max": 0.06}'

``--fit`` registers every scan (one process, one thread) and writes per-scan rows (V2V and
MPJPE in mm, CPU s, garment category) to OUT.json, printing per-category means.
``--seeds 0,1,2`` fits every scan once per registrar sampling seed (which scan and body
points the fit uses) and also prints the mean per seed and the scans whose V2V moves most
between seeds: a single fit can flip between two starting hypotheses on a float-level
difference (another seed, another CPU), so compare variants over several seeds.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time


def make(out: str, subjects: int = 6, poses: int = 3, seed: int = 1, workers: int = 1,
         pose_set: str = "generator") -> str:
    """Generate (or resume) the tuning dataset in ``out``; returns its path."""
    from dressmeup.data.synth.common import plan_2x
    from dressmeup.data.synth.generate import generate_dataset
    from dressmeup.data.synth.poses import pose_names

    tuning = {"a-pose", "walking", "arms-raised", "sitting"} | \
        set(pose_names("registration-tuning"))
    if pose_set not in ("generator", "registration-tuning"):
        raise SystemExit(f"--pose-set: {pose_set!r} is not a tuning set")
    plan = plan_2x(subjects, poses, (0, 0, 2), seed, pose_set=pose_set, wear="rotate")
    bad = [p for p in plan["poses"].values() if p not in tuning]
    if bad:
        raise SystemExit(f"poses {bad} are not tuning poses: use --poses <= 3")
    return str(generate_dataset(out, subjects=subjects, poses=poses, seed=seed,
                                version="2.1.0", garments_per_split=(0, 0, 2), pose_steps=3,
                                pose_set=pose_set, wear="rotate", scan_body="uncovered",
                                workers=workers))


def fit(root: str, options: dict, only: str = "", seeds: tuple[int, ...] = (0,)) -> list[dict]:
    """Register every scan of ``root`` (sample ids containing ``only``) once per registrar
    ``seeds`` entry; rows per scan and seed."""
    from dressmeup.body import get_body_model
    from dressmeup.data import Dataset

    ds = Dataset(root)
    m = ds.manifest.set_index("sample_id")
    rows = []
    for sid in m.index:
        if only and not any(o in sid for o in only.split(",")):
            continue
        sample = ds[sid]
        truth = sample.body()
        model = get_body_model(truth.model)
        labels = {"sample": sid, "pose": ds.info["poses"][m.loc[sid, "pose_id"]],
                  "category": str(m.loc[sid, "category"]),
                  "garment": str(m.loc[sid, "garment_type"])}
        scan = sample.scan()  # read once for all seeds
        for seed in seeds:
            rows.append(_fit_one(scan, truth, model, {**options, "seed": seed}, labels))
    return rows


def _fit_one(scan, truth, model, options: dict, labels: dict) -> dict:
    """Register ``scan`` with ``options``; its row (``labels`` + errors, timing, start),
    printed."""
    import numpy as np

    from dressmeup.body.registration import register

    cpu = time.process_time()
    res = register(scan, model, return_result=True, **{"verbose": False, **options})
    cpu = time.process_time() - cpu
    a, b = model.posed(res.params), model.posed(truth)
    row = {**labels, "seed": options["seed"],
           "v2v_mm": float(np.linalg.norm(a.vertices - b.vertices, axis=1).mean() * 1000),
           "mpjpe_mm": float(np.linalg.norm(a.joints - b.joints, axis=1).mean() * 1000),
           "cpu_s": cpu, "load": os.getloadavg()[0], "init": res.info.get("init", ""),
           "far_cloth_branch": (res.info.get("far_cloth_branches") or {}).get("kept", ""),
           "params": {"shape": res.params.shape.tolist(), "pose": res.params.pose.tolist(),
                      "transl": res.params.transl.tolist()}}
    print(f"{row['sample']:<14}{row['pose']:<13}{row['category']:<12}{row['seed']:>3}"
          f"{row['v2v_mm']:7.1f}{row['mpjpe_mm']:7.1f}{cpu:7.1f}{row['load']:5.1f}  {row['init']}"
          + (f"; far cloth branch: {row['far_cloth_branch']}" if row["far_cloth_branch"]
             else ""), flush=True)
    return row


def summary(rows: list[dict]) -> list[str]:
    """Lines of means per category, per pose, per seed and overall, and (several seeds) the
    scans whose V2V differs most between seeds (max - min, mm)."""
    import numpy as np

    out = []
    for key in ("category", "pose", "seed"):
        for val in sorted({r[key] for r in rows}):
            sel = [r["v2v_mm"] for r in rows if r[key] == val]
            out.append(f"{key} {val!s:<12} v2v {np.mean(sel):6.1f} mm ({len(sel)} fits)")
    spread = {}
    for r in rows:
        spread.setdefault(r["sample"], []).append(r["v2v_mm"])
    moved = sorted(((max(v) - min(v), s, v) for s, v in spread.items() if len(v) > 1),
                   reverse=True)
    for d, s, v in moved[:5]:
        if d >= 5.0:
            out.append(f"seed spread {s:<14} {d:6.1f} mm ({', '.join(f'{x:.1f}' for x in v)})")
    out.append(f"all v2v {np.mean([r['v2v_mm'] for r in rows]):.1f} mm, CPU "
               f"{np.mean([r['cpu_s'] for r in rows]):.1f} s/fit")
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out", help="dataset folder (made if missing)")
    ap.add_argument("--subjects", type=int, default=6)
    ap.add_argument("--poses", type=int, default=3)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--pose-set", default="generator",
                    help="generator (sitting, arms-raised, walking) or registration-tuning "
                    "(bowing, picking-up, stepping-up, lunge, marching, leaning-over, "
                    "half-squat-reach, in this order: --poses N takes the first N)")
    ap.add_argument("--fit", help="register every scan and write rows to this JSON file")
    ap.add_argument("--options", default="", help="registrar options as JSON")
    ap.add_argument("--only", default="", help="comma list of sample-id parts to fit")
    ap.add_argument("--seeds", default="0", help="comma list of registrar sampling seeds; "
                    "every scan is fitted once per seed")
    args = ap.parse_args(argv)
    os.environ.setdefault("DRESSMEUP_NO_PROGRESS", "1")
    from pathlib import Path

    if args.fit and (Path(args.out) / "manifest.parquet").is_file():
        root = args.out  # made already: resuming would rewrite the manifest, and concurrent
        # --fit runs (e.g. --only S01,S02 and --only S03,S04) would race on it
    else:
        root = make(args.out, args.subjects, args.poses, args.seed, pose_set=args.pose_set)
    if not args.fit:
        return 0
    import torch

    options = json.loads(args.options or "{}")
    if "seed" in options:
        raise SystemExit("--options: give the registrar seed with --seeds, not as an option")
    try:
        seeds = tuple(int(x) for x in args.seeds.split(",") if x.strip())
    except ValueError:
        raise SystemExit(f"--seeds: expected a comma list of integers, got {args.seeds!r}") \
            from None
    torch.set_num_threads(1)
    rows = fit(root, options, args.only, seeds or (0,))
    print("\n".join(summary(rows)))
    from dressmeup.io.atomic import atomic_write_text

    atomic_write_text(args.fit, json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
