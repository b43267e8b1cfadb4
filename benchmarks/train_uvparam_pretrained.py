"""Train the shipped pretrained neural UV models on the synth-uvparam-v2 mesh set, or on a
generator-4 dataset's garments (``--garments-from``: the v5 train split's garments as
designed, validated on its val split's).

Models: one per garment category (``topwear``, ``bottomwear``, ``dress``: the category's
*train* garments, validated on its *val* garments) and one ``general`` model (the train
garments of every category plus smoothly warped copies of the test shapes -- never the test
meshes themselves -- validated on the val garments and other warped shapes). Each model gets
a wall-clock budget and stops earlier when its validation loss improves by less than 1 % over
the last fifth of training and at least one pass over its training meshes
(``dressmeup.methods.nn.convergence.converged``).

Writes ``dressmeup/methods/uvparam/weights/neural_<model>.pt`` (float16), a JSON log per model
in ``benchmarks/results/studies/<date>-uvparam_pretrained_<model>.json`` and learning curves in
``docs/images/uvparam_learning_<model>.png``.

    nice -n 10 python benchmarks/train_uvparam_pretrained.py --data DATA --models topwear dress \\
        --budget-minutes 35
    dressmeup synth V5_GARMENTS --edition synth-retarget-v5 --designed-garments --workers 2
    python benchmarks/train_uvparam_pretrained.py --data V5_GARMENTS --garments-from \\
        --budget-minutes 0 --uv-iters 100000 --patch-iters 5000 --checkpoints CKPT_DIR

A variant is tried apart and compared on the validation meshes before it replaces a shipped
model (every log records ``val_quality``: mean QCE and flipped share of the model's maps of
its validation garments and warped shapes):

    python benchmarks/train_uvparam_pretrained.py --data V5_GARMENTS --garments-from \\
        --models general --warp-copies 4 --out TRIAL --budget-minutes 0 --uv-iters 100000 \\
        --patch-iters 5000 --checkpoints TRIAL_CKPT
    python benchmarks/train_uvparam_pretrained.py --data V5_GARMENTS --garments-from \\
        --models general --evaluate-only            # the shipped model, same meshes

With ``--checkpoints DIR`` each model's whole training state is written to
``DIR/neural_<model>.ckpt`` every ``--checkpoint-minutes`` (at validation steps): the same
command run again resumes every model where it stopped, and finished models are written out
again from their checkpoints without training.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from datetime import date
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
WEIGHTS = REPO / "dressmeup" / "methods" / "uvparam" / "weights"
RESULTS = REPO / "benchmarks" / "results" / "studies"
IMAGES = REPO / "docs" / "images"
CATEGORIES = ("topwear", "bottomwear", "dress")
WARP_SHAPES = ("sphere-2k", "torus-2k", "blob-2k", "sheet-2k", "skirt-2k")


def warped(mesh_id: str, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A smooth random deformation of a test shape (anisotropic scale + two sine waves):
    a different mesh of a similar kind, so the general model never sees the test meshes."""
    from dressmeup.data.shapes import make_test_mesh

    V, F = make_test_mesh(mesh_id)
    rng = np.random.default_rng(seed)
    V = V * rng.uniform(0.7, 1.4, size=3)
    ext = float(np.linalg.norm(V.max(0) - V.min(0)))
    for _ in range(2):
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        a = rng.normal(size=3)
        V = V + 0.04 * ext * np.sin(2 * np.pi * rng.uniform(0.8, 2.0) * (V @ d) / ext
                                    + rng.uniform(0, 2 * np.pi))[:, None] * a / np.linalg.norm(a)
    return V, F


def garment_meshes(root: Path, split: str, cats) -> tuple[list, list[str]]:
    """The rest garments (as designed, ``generator/rest/<G>.ply``) of a generator-4 dataset's
    ``split`` in the categories ``cats`` (a generated dataset, or the garments alone written
    by ``dressmeup synth --edition E --designed-garments``): ``([(V, F), ...], [garment id,
    ...])``."""
    from dressmeup.data.synth.designed4 import designed_garments
    from dressmeup.errors import InputError
    from dressmeup.io.mesh import load_mesh

    try:
        garments = designed_garments(root, split, cats)
    except InputError as exc:
        raise SystemExit(f"--garments-from: {exc}") from exc
    out = []
    for _, _, path in garments:
        m = load_mesh(path)
        out.append((np.asarray(m.vertices, np.float64), np.asarray(m.faces, np.int64)))
    return out, [g for g, _, _ in garments]


def mesh_sets(data: Path, model: str, garments: bool = False, warp_copies: int = 1):
    """Training and validation meshes of ``model``: ``(train, train_ids, val, val_ids)``, each
    mesh ``(V (n, 3) float64, F (m, 3) int64)``. The ``general`` model's training set also holds
    ``warp_copies`` warped copies of each of :data:`WARP_SHAPES` (seeds ``100 + k + 10 j``,
    copy ``j`` of shape ``k``); its validation set holds the same warped shapes at other
    seeds (``200 + k``, every other shape) whatever ``warp_copies`` is."""
    from dressmeup.bench.tasks.uvparam.data import meshes
    from dressmeup.io.mesh import load_mesh

    def load(split, cats):
        if garments:
            return garment_meshes(data, split, cats)
        out = [m for m in meshes(data, split) if m.category in cats]
        return [(lambda mm: (mm.vertices, mm.faces))(load_mesh(m.path)) for m in out], \
            [m.mesh_id for m in out]

    cats = CATEGORIES if model == "general" else (model,)
    train, train_ids = load("train", cats)
    val, val_ids = load("val", cats)
    if model == "general":
        for k, sid in enumerate(WARP_SHAPES):
            for j in range(warp_copies):
                train.append(warped(sid, 100 + k + 10 * j))
                train_ids.append(f"warped-{sid}-{100 + k + 10 * j}")
            if k % 2 == 0:
                val.append(warped(sid, 200 + k))
                val_ids.append(f"warped-{sid}-{200 + k}")
    return train, train_ids, val, val_ids


def val_quality(model_path: Path, val: list, val_ids: list[str]) -> dict:
    """The model's maps of its validation meshes scored by the uvparam task: mean QCE and
    flipped share over the garments and over the warped shapes apart (``{"garments": {"n",
    "qce", "flip"}, "shapes": {...}}``; a group without meshes is left out). What a choice
    between trained variants reads: never a test mesh."""
    from dressmeup.bench.tasks.uvparam.evaluate import evaluate_uv
    from dressmeup.methods.uvparam import get_method

    method = get_method("neural", checkpoint=model_path)
    groups: dict[str, list] = {}
    for (V, F), mid in zip(val, val_ids, strict=True):
        res = method.parameterize(V, F)
        vals = evaluate_uv(V, F, res.uv, res.uv_faces, ("qce", "flip"), {})
        groups.setdefault("shapes" if mid.startswith("warped-") else "garments", []).append(vals)
    return {g: {"n": len(rows), "qce": float(np.mean([r["qce"] for r in rows])),
                "flip": float(np.mean([r["flip"] for r in rows]))} for g, rows in groups.items()}


def data_record(root: Path, garments: bool) -> dict:
    """What the model was trained on: the folder and the sha256 of its record file."""
    from dressmeup.data.synth.designed4 import garment_record
    from dressmeup.io.hashing import sha256_file

    record = garment_record(root) if garments else root / "dataset.json"
    if not record.is_file():
        return {"root": str(root)}
    return {"root": str(root), "record": str(record.relative_to(root)),
            "sha256": sha256_file(record)}


def plot_curves(hist: dict, title: str, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 2, figsize=(10, 3.6))
    for a, tr, va, name in ((ax[0], "patch_total", "val_patch", "PatchNet"),
                            (ax[1], "uv_total", "val_uv", "UV MLPs")):
        y = np.asarray(hist[tr], float)
        if y.size:
            k = max(1, y.size // 20)
            sm = np.convolve(y, np.ones(k) / k, mode="valid")
            a.plot(np.arange(1, y.size + 1), y, color="0.8", lw=0.6, label="train (per step)")
            a.plot(np.arange(k, y.size + 1), sm, color="C0", lw=1.2, label=f"train ({k}-step mean)")
        if hist[va]:
            v = np.asarray(hist[va], float)
            a.plot(v[:, 0], v[:, 1], "o-", color="C3", ms=3, label="validation")
        a.set_yscale("log")
        a.set_xlabel("step")
        a.set_title(f"{name}: stopped by {hist['stopped'].get('patchnet' if tr == 'patch_total' else 'uv')}")
        a.legend(fontsize=7)
    fig.suptitle(title, fontsize=9)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", required=True, type=Path,
                    help="synth-uvparam-v2 mesh set root, or with --garments-from a "
                         "generator-4 dataset (its train and val garments as designed)")
    ap.add_argument("--garments-from", action="store_true",
                    help="--data is a generator-4 dataset (v5): train on its train split's "
                         "garments, validate on its val split's")
    ap.add_argument("--models", nargs="+", default=[*CATEGORIES, "general"],
                    choices=[*CATEGORIES, "general"])
    ap.add_argument("--budget-minutes", type=float, default=60.0,
                    help="wall budget per model (0: none; the convergence rule or the step "
                         "limits stop it)")
    ap.add_argument("--config", default="reference", choices=["reference", "fast"])
    ap.add_argument("--uv-iters", type=int, default=4000, help="UV step limit")
    ap.add_argument("--patch-iters", type=int, default=300, help="PatchNet step limit")
    ap.add_argument("--eval-every", type=int, default=25)
    ap.add_argument("--train-vertices", type=int, default=2500)
    ap.add_argument("--checkpoints", type=Path, default=None, metavar="DIR",
                    help="resumable training: each model's state in DIR/neural_<model>.ckpt")
    ap.add_argument("--checkpoint-minutes", type=float, default=5.0)
    ap.add_argument("--warp-copies", type=int, default=1,
                    help="warped copies of each test shape in the general model's training set")
    ap.add_argument("--out", type=Path, default=None, metavar="DIR",
                    help="write the weights, logs and curves to DIR instead of the shipped "
                         "places (a trial to compare on val before shipping)")
    ap.add_argument("--evaluate-only", action="store_true",
                    help="train nothing: print the validation quality of the models in the "
                         "weights folder (the shipped ones, or --out's)")
    args = ap.parse_args(argv)
    weights_dir, results_dir, images_dir = ((args.out,) * 3 if args.out else (WEIGHTS, RESULTS, IMAGES))

    import torch

    from dressmeup.methods.nn.record import training_machine
    from dressmeup.methods.uvparam.neural.model import save_model
    from dressmeup.methods.uvparam.neural.train_set import train_on_set

    torch.set_num_threads(1)
    for model in args.models:
        train, train_ids, val, val_ids = mesh_sets(args.data, model, args.garments_from, args.warp_copies)
        if args.evaluate_only:
            print(f"{model} ({weights_dir / f'neural_{model}.pt'}): validation quality "
                  f"{json.dumps(val_quality(weights_dir / f'neural_{model}.pt', val, val_ids))}", flush=True)
            continue
        print(f"[{time.strftime('%H:%M:%S')}] {model}: {len(train)} train, {len(val)} val meshes, "
              f"budget {args.budget_minutes} min, load {os.getloadavg()}", flush=True)

        def on_eval(stage, step, v, model=model):
            print(f"  {model} {stage} step {step}: val {v:.5f}  load {os.getloadavg()[0]:.1f}",
                  flush=True)

        t0 = time.time()
        budget = 60 * args.budget_minutes if args.budget_minutes > 0 else float("inf")
        m = train_on_set(train, val, args.config, budget_seconds=budget,
                         eval_every=args.eval_every, on_eval=on_eval,
                         uv_iters=args.uv_iters, patch_iters=args.patch_iters,
                         train_vertices=args.train_vertices,
                         checkpoint=(args.checkpoints / f"neural_{model}.ckpt"
                                     if args.checkpoints else None),
                         checkpoint_every_s=60 * args.checkpoint_minutes)
        m.history.update(train_ids=train_ids, val_ids=val_ids, model=model,
                         load_avg_end=list(os.getloadavg()),
                         wall_seconds=m.history.get("seconds_total", time.time() - t0))
        weights_dir.mkdir(parents=True, exist_ok=True)
        ckpt = weights_dir / f"neural_{model}.pt"
        save_model(m, ckpt, half=True)
        log = {k: v for k, v in m.history.items()}
        results_dir.mkdir(parents=True, exist_ok=True)
        from dressmeup.methods.uvparam.neural.model import plain_values

        (results_dir / f"{date.today():%Y-%m-%d}-uvparam_pretrained_{model}.json").write_text(json.dumps(
            {"config": args.config, "budget_minutes": args.budget_minutes, "warp_copies": args.warp_copies,
             "data": data_record(args.data, args.garments_from), "machine": training_machine(),
             "val_quality": val_quality(ckpt, val, val_ids),
             "passes": {"patchnet": round(m.history["patch_steps"] / len(train), 1),
                        "uv": round(m.history["uv_steps"] / len(train), 1)},
             "checkpoint_bytes": ckpt.stat().st_size, "n_parameters": m.n_parameters,
             **plain_values(log)}, indent=1) + "\n")
        plot_curves(m.history, f"neural UV '{model}' ({args.config} sizes): {len(train)} train / "
                    f"{len(val)} val meshes, {m.history['patch_steps']} + {m.history['uv_steps']} "
                    f"steps in {m.history['seconds_total'] / 60:.1f} min (load ~{os.getloadavg()[0]:.0f})",
                    images_dir / f"uvparam_learning_{model}.png")
        print(f"[{time.strftime('%H:%M:%S')}] {model}: stopped {m.history['stopped']}, "
              f"{ckpt.stat().st_size / 1e6:.2f} MB -> {ckpt}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
