"""Training on a *set* of meshes (a category of garments, or varied shapes), for inference on
meshes the networks never saw (the thesis' per-category set-up, Table 3.1).

One PatchNet and one pair of UV MLPs serve the whole set: every step takes one training mesh
(a shuffled round robin), so the networks must find patches and maps that work across the
set, and the chart code psi tells the meshes' charts apart. A validation set (other meshes)
is scored every ``eval_every`` steps; a stage stops when its validation loss improved by less
than ``tol`` (1 %) over the last fifth of its steps and at least one pass over the training
meshes (:func:`~dressmeup.methods.nn.convergence.converged`), when its share of the
wall-clock budget is spent, or at its step limit -- whichever comes first;
``history["stopped"]`` says which.

Meshes are decimated to ``NeuralConfig.train_vertices`` first (the networks are
discretisation-agnostic, so the trained model runs on any resolution afterwards).

With a ``checkpoint`` file the whole state (networks, optimiser, best states, histories,
the random streams of the mesh order and the UV pairs) is written atomically at
validation steps every ``checkpoint_every_s`` seconds and at the end of each stage; a run
given an existing checkpoint goes on from it and ends as the uninterrupted run would have.
"""

from __future__ import annotations

import io
import logging
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
from scipy.sparse.csgraph import dijkstra

from dressmeup.cache import hash_arrays
from dressmeup.errors import InputError
from dressmeup.geometry.mesh import as_arrays, face_areas, face_normals
from dressmeup.io.atomic import atomic_write_bytes
from dressmeup.methods.nn.checkpoint import load_checkpoint
from dressmeup.methods.nn.convergence import converged
from dressmeup.methods.nn.diffusion_ops import compute_operators
from dressmeup.methods.uvparam.neural import losses as L
from dressmeup.methods.uvparam.neural.model import (
    NeuralConfig,
    NeuralUVModel,
    build_modules,
    get_config,
    plain_values,
)
from dressmeup.methods.uvparam.neural.patchnet import (
    assign_charts,
    normalize_vertices,
    patchnet_inputs,
)
from dressmeup.methods.uvparam.neural.train import (
    _edge_graph,
    _iso_pairs,
    chart_codes,
    chart_rows,
)
from dressmeup.progress import progress as bar

__all__ = ["train_on_set", "mesh_sha"]

log = logging.getLogger(__name__)
#: least window (steps) over which the convergence rule compares the validation loss, besides
#: one pass over the training set: the UV stage's validation loss has a slow phase of up to
#: ~250 steps before it falls 10-50x (steps ~100-350 on the garment models' validation
#: curves), which a window of the last fifth alone can mistake for convergence
#: (docs/uvparam.md, "Pretrained models")
MIN_WINDOW_STEPS = 500
#: ``format`` of a set training's checkpoint
CKPT_FORMAT = "dressmeup-uvparam-set-training-1"
#: the per-step loss series of a training's history
_SERIES = ("patch_total", "cos", "geo", "uv_total", "cycle", "iso", "angle", "area")


def mesh_sha(V: np.ndarray, F: np.ndarray) -> str:
    """Hash of a mesh's arrays (float64 vertices, int64 faces): how a checkpoint remembers
    the meshes it was trained on, so that a benchmark run can tell seen from unseen meshes."""

    V, F = as_arrays(V, F)
    return hash_arrays(np.ascontiguousarray(V, dtype=np.float64),
                       np.ascontiguousarray(F, dtype=np.int64))


@dataclass
class _PatchData:
    Vn: np.ndarray
    F: np.ndarray
    ops: Any
    tops: dict
    x: Any
    Gt: Any
    mass_lm: Any
    fn: Any
    fa: Any
    Ft: Any
    lm: Any


def _prepare(V, F, cfg: NeuralConfig, rng: np.random.Generator) -> _PatchData:
    # heavy: torch, igl
    import torch

    from dressmeup.geometry.simplify import decimate

    V, F = decimate(*as_arrays(V, F), cfg.train_vertices)
    Vn = normalize_vertices(V)
    ops = compute_operators(Vn, F, k_eig=cfg.k_eig)
    n = len(Vn)
    lm = np.sort(rng.choice(n, size=min(n, cfg.geo_landmarks), replace=False))
    G = dijkstra(_edge_graph(Vn, F), directed=False, indices=lm)[:, lm]
    G = np.where(np.isfinite(G), G, 2.0 * np.nanmax(np.where(np.isfinite(G), G, 0.0)))
    return _PatchData(Vn, F, ops, ops.to_torch(), torch.from_numpy(patchnet_inputs(Vn, F)),
                      torch.from_numpy(G.astype(np.float32)),
                      torch.from_numpy(ops.mass[lm].astype(np.float32)),
                      torch.from_numpy(face_normals(Vn, F).astype(np.float32)),
                      torch.from_numpy(face_areas(Vn, F).astype(np.float32)),
                      torch.from_numpy(F), torch.from_numpy(lm))


def _patch_loss(patchnet, d: _PatchData, cfg: NeuralConfig):
    probs = patchnet(d.x, d.tops)
    lc = L.cosine_loss(probs[d.Ft].mean(dim=1), d.fn, d.fa)
    lg = L.geodesic_loss(probs[d.lm], d.mass_lm, d.Gt)
    return cfg.lambda_cos * lc + cfg.lambda_geo * lg, lc, lg


def _uv_data(d: _PatchData, patchnet, cfg: NeuralConfig) -> dict:
    # heavy: torch (~1.1 s to import)
    import torch

    with torch.no_grad():
        h = patchnet.features(d.x, d.tops)
        probs = torch.softmax(patchnet.last(h), dim=-1).numpy()
        feats = h.numpy()
    chart_ids = assign_charts(d.Vn, d.F, probs, cfg.consolidation_steps, cfg.min_chart_fraction)
    psi = chart_codes(feats, d.ops.mass, d.F, chart_ids)
    row_vertex, row_chart, row_faces = chart_rows(d.F, chart_ids)
    pairs, gdist = _iso_pairs(d.Vn, row_vertex, row_chart, row_faces, cfg.sigma)
    xr = torch.from_numpy(d.Vn[row_vertex].astype(np.float32))
    psi_r = torch.from_numpy(psi[row_chart])
    rf = torch.from_numpy(row_faces)
    return {"xr": xr, "psi_r": psi_r, "inp": torch.cat([xr, psi_r], dim=1), "rf": rf,
            "cos3d": L.triangle_cosines(xr, rf).detach(), "area3d": L.triangle_areas_3d(xr, rf).detach(),
            "pairs": torch.from_numpy(pairs), "gd": torch.from_numpy(gdist.astype(np.float32)),
            "n_charts": int(chart_ids.max()) + 1}


def _uv_loss(fwd, bwd, u: dict, cfg: NeuralConfig, gen):
    # heavy: torch (~1.1 s to import)
    import torch

    uv = fwd(u["inp"])
    rec = bwd(torch.cat([uv, u["psi_r"]], dim=1))
    lcyc = L.cycle_loss(u["xr"], rec)
    pairs, gd = u["pairs"], u["gd"]
    if len(pairs) > cfg.pairs_per_iter:
        sel = torch.randint(len(pairs), (cfg.pairs_per_iter,), generator=gen)
        pairs, gd = pairs[sel], gd[sel]
    liso = L.isometric_loss(uv, pairs, gd) if len(pairs) else uv.sum() * 0.0
    lang = L.angle_loss(uv, u["rf"], u["cos3d"])
    lar = L.area_loss(uv, u["rf"], u["area3d"])
    w = cfg.weights
    return w[0] * lcyc + w[1] * liso + w[2] * lang + w[3] * lar, (lcyc, liso, lang, lar)


def train_on_set(train_meshes: Sequence[tuple[np.ndarray, np.ndarray]],
                 val_meshes: Sequence[tuple[np.ndarray, np.ndarray]],
                 config: str | NeuralConfig = "fast", *, budget_seconds: float = 3600.0,
                 patch_share: float = 0.25, eval_every: int = 25, tol: float = 0.01,
                 threads: int | None = 1, progress: bool = False,
                 on_eval: Callable[[str, int, float], None] | None = None,
                 checkpoint: str | os.PathLike | None = None,
                 checkpoint_every_s: float = 300.0,
                 **overrides: Any) -> NeuralUVModel:
    """Train one PatchNet and one pair of UV MLPs on a set of meshes.

    Parameters
    ----------
    train_meshes, val_meshes : sequences of ``(V (n, 3) float, F (m, 3) int)``.
    config : ``"fast"``, ``"reference"`` or a :class:`NeuralConfig`; ``patch_iters`` and
        ``uv_iters`` are the stages' step *limits* here.
    budget_seconds : wall-clock budget of this invocation (preparation included; a resumed
        run gets it again).
    patch_share : share of the budget left after preparation that PatchNet may use.
    eval_every : steps between validation evaluations.
    tol : convergence threshold of :func:`converged` (relative, over the last fifth of the
        steps, a window of at least one pass over the set and :data:`MIN_WINDOW_STEPS`).
    threads : torch intra-op threads (1 on a shared machine).
    progress : show progress bars.
    on_eval : called as ``on_eval(stage, step, val_loss)`` after every evaluation.
    checkpoint : file of the training's whole state (module docstring); resumed from when
        it exists (its meshes and configuration must be this run's).
    checkpoint_every_s : seconds between checkpoints (written at validation steps).
    **overrides : fields of :class:`NeuralConfig`.

    Returns
    -------
    NeuralUVModel
        ``history``: per-step ``patch_total``/``cos``/``geo``/``uv_total``/``cycle``/
        ``iso``/``angle``/``area``; ``val_patch``/``val_uv`` as ``[[step, loss], ...]``;
        ``stopped`` (``{"patchnet": ..., "uv": ...}``: ``converged``/``budget``/``max_iters``);
        ``seconds_*``; ``train_mesh_sha`` (hashes of the training meshes as given).

    Raises
    ------
    ValueError
        No training or no validation meshes, or an invalid configuration.
    InputError
        A checkpoint of other meshes or another configuration, or not a checkpoint.
    """
    # heavy: torch (~1.1 s to import)
    import torch

    if not train_meshes or not val_meshes:
        raise ValueError("train_on_set: needs at least one training and one validation mesh")
    cfg = get_config(config, **overrides)
    old = torch.get_num_threads()
    if threads:
        torch.set_num_threads(int(threads))
    try:
        ck = _Checkpoint(Path(checkpoint), checkpoint_every_s) if checkpoint else None
        return _train_on_set(train_meshes, val_meshes, cfg, budget_seconds, patch_share,
                             eval_every, tol, progress, on_eval, ck)
    finally:
        torch.set_num_threads(old)


class _Checkpoint:
    """A set training's checkpoint file: :meth:`due` every ``every_s`` seconds,
    :meth:`save` (atomic), :meth:`load` (None when there is none)."""

    def __init__(self, path: Path, every_s: float) -> None:
        self.path, self.every_s = path, float(every_s)
        self.last = time.perf_counter()

    def due(self) -> bool:
        return time.perf_counter() - self.last >= self.every_s

    def save(self, state: dict) -> None:
        # heavy: torch (~1.1 s to import)
        import torch

        buf = io.BytesIO()
        torch.save({"format": CKPT_FORMAT, **state}, buf)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_bytes(self.path, buf.getvalue())
        self.last = time.perf_counter()

    def load(self) -> dict | None:
        if not self.path.is_file():
            return None
        return load_checkpoint(self.path, "UV training checkpoint", CKPT_FORMAT,
                               ("stage", "step", "config", "train_mesh_sha", "modules"))


def _train_on_set(train_meshes, val_meshes, cfg, budget, patch_share, eval_every, tol,
                  progress, on_eval, ck: _Checkpoint | None = None) -> NeuralUVModel:
    # heavy: torch (~1.1 s to import)
    import torch

    t0 = time.perf_counter()
    rng = np.random.default_rng(cfg.seed)
    shas = [mesh_sha(V, F) for V, F in train_meshes]
    train = [_prepare(V, F, cfg, rng) for V, F in bar(list(train_meshes), desc="operators (train)",
                                                       disable=not progress or None)]
    val = [_prepare(V, F, cfg, rng) for V, F in val_meshes]
    t_prep = time.perf_counter()
    left = budget - (t_prep - t0)
    patchnet, fwd, bwd = build_modules(cfg)
    hist: dict = {k: [] for k in _SERIES}
    hist.update(val_patch=[], val_uv=[], stopped={}, train_mesh_sha=shas,
                n_train=len(train), n_val=len(val), seconds_prepare=t_prep - t0,
                budget_seconds=float(budget))

    def order(step: int) -> int:
        k = step % len(train)
        if k == 0:
            order.perm = rng.permutation(len(train))
        return int(order.perm[k])

    order.perm = rng.permutation(len(train))
    resume = ck.load() if ck is not None else None
    if resume is not None:
        if resume["train_mesh_sha"] != shas or resume["config"] != plain_values(asdict(cfg)):
            raise InputError(f"UV training checkpoint {ck.path}: made for other training "
                             "meshes or another configuration; delete it to start over")
        for mod, key in ((patchnet, "patchnet"), (fwd, "fwd"), (bwd, "bwd")):
            mod.load_state_dict(resume["modules"][key])
        hist = {k: v.tolist() if k in _SERIES else v for k, v in resume["hist"].items()}
        rng.bit_generator.state = resume["rng"]
        order.perm = np.asarray(resume["perm"], np.int64)
        log.info("resumed %s: %s stage, step %d", ck.path, resume["stage"], resume["step"])

    def snapshot(stage: str, step: int, stage_state: dict | None = None) -> None:
        """Write the whole state (``stage_state``: the running stage's optimiser, best
        state and value, and the UV pairs' generator)."""
        if ck is None:
            return
        ck.save({"stage": stage, "step": int(step), "config": plain_values(asdict(cfg)),
                 "train_mesh_sha": shas,
                 # the per-step series as tensors: a long run's lists would be millions of
                 # pickled objects
                 "hist": {k: torch.tensor(v, dtype=torch.float64) if k in _SERIES
                          else plain_values(v) for k, v in hist.items()},
                 "modules": {"patchnet": patchnet.state_dict(), "fwd": fwd.state_dict(),
                             "bwd": bwd.state_dict()},
                 "rng": rng.bit_generator.state, "perm": [int(i) for i in order.perm],
                 "stage_state": stage_state})

    stage = resume["stage"] if resume is not None else "patchnet"
    if stage == "patchnet":
        patch_stop = _fit_patchnet_on_set(
            patchnet, train, val, cfg, order, t_prep + patch_share * left, eval_every, tol,
            hist, progress, on_eval, snapshot, ck,
            resume if resume is not None and resume["stage"] == "patchnet" else None)
        hist["stopped"]["patchnet"] = patch_stop
        hist["patch_steps"] = len(hist["patch_total"])
        hist["seconds_patchnet"] = hist.get("seconds_patchnet", 0.0) + (
            time.perf_counter() - t_prep)
        snapshot("uv", 0)
    patchnet.eval()
    t1 = time.perf_counter()
    if stage != "done":
        train_uv = [_uv_data(d, patchnet, cfg) for d in train]
        val_uv = [_uv_data(d, patchnet, cfg) for d in val]
        hist["n_charts_train"] = [u["n_charts"] for u in train_uv]
        hist["stopped"]["uv"] = _fit_uv_on_set(
            fwd, bwd, train_uv, val_uv, cfg, order, t0 + budget, eval_every, tol, hist,
            progress, on_eval, snapshot, ck,
            resume if resume is not None and resume["stage"] == "uv" else None)
        hist["uv_steps"] = len(hist["uv_total"])
        hist["seconds_uv"] = hist.get("seconds_uv", 0.0) + time.perf_counter() - t1
        hist["seconds_total"] = hist.get("seconds_total", 0.0) + time.perf_counter() - t0
        snapshot("done", hist["uv_steps"])
    return NeuralUVModel(cfg, patchnet, fwd.eval(), bwd.eval(), hist)


def _fit_patchnet_on_set(patchnet: Any, train: list[dict], val: list[dict], cfg: NeuralConfig,
                         order: Callable[[int], int], deadline: float, eval_every: int,
                         tol: float, hist: dict, progress: bool,
                         on_eval: Callable[[str, int, float], None] | None,
                         snapshot: Callable[..., None] | None = None,
                         ck: _Checkpoint | None = None, resume: dict | None = None) -> str:
    """PatchNet over the set, one training mesh per step (in ``order``), evaluated on ``val``
    every ``eval_every`` steps; keeps the best state on ``val`` (left in eval mode). Returns
    why it stopped: ``converged``, ``budget`` (past ``deadline``) or ``max_iters``.
    ``snapshot(stage, step, stage_state)`` writes a checkpoint when ``ck`` is due;
    ``resume``: a checkpoint of this stage to go on from."""
    # heavy: torch (~1.1 s to import)
    import torch

    opt = torch.optim.Adam(patchnet.parameters(), lr=cfg.patch_lr)
    stop = "max_iters"
    best_state, best_val, start = None, np.inf, 0
    if resume is not None:
        st = resume["stage_state"]
        opt.load_state_dict(st["opt"])
        best_state, best_val, start = st["best_state"], float(st["best_val"]), resume["step"]
    for step in bar(range(start + 1, cfg.patch_iters + 1), desc="PatchNet",
                    disable=not progress or None):
        loss, lc, lg = _patch_loss(patchnet, train[order(step - 1)], cfg)
        opt.zero_grad()
        loss.backward()
        opt.step()
        hist["patch_total"].append(float(loss.detach()))
        hist["cos"].append(float(lc.detach()))
        hist["geo"].append(float(lg.detach()))
        if step % eval_every == 0 or step == cfg.patch_iters:
            with torch.no_grad():
                v = float(np.mean([float(_patch_loss(patchnet, d, cfg)[0]) for d in val]))
            hist["val_patch"].append([step, v])
            if on_eval:
                on_eval("patchnet", step, v)
            if v < best_val:
                best_val, best_state = v, {k: t.clone() for k, t in patchnet.state_dict().items()}
            if converged(hist["val_patch"], tol, min_window=max(len(train), MIN_WINDOW_STEPS)):
                stop = "converged"
                break
            if ck is not None and ck.due():
                snapshot("patchnet", step, {"opt": opt.state_dict(), "best_state": best_state,
                                            "best_val": best_val})
        if time.perf_counter() > deadline:
            stop = "budget"
            break
    if best_state is not None:
        patchnet.load_state_dict(best_state)
    patchnet.eval()
    return stop


def _fit_uv_on_set(fwd: Any, bwd: Any, train_uv: list[dict], val_uv: list[dict],
                   cfg: NeuralConfig, order: Callable[[int], int], deadline: float,
                   eval_every: int, tol: float, hist: dict, progress: bool,
                   on_eval: Callable[[str, int, float], None] | None,
                   snapshot: Callable[..., None] | None = None,
                   ck: _Checkpoint | None = None, resume: dict | None = None) -> str:
    """The UV MLPs over the set, as :func:`_fit_patchnet_on_set` (validation pairs drawn
    the same at every evaluation); keeps the best pair of states. Returns why it stopped."""
    # heavy: torch (~1.1 s to import)
    import torch

    params = list(fwd.parameters()) + list(bwd.parameters())
    opt = torch.optim.Adam(params, lr=cfg.uv_lr)
    gen = torch.Generator().manual_seed(cfg.seed)
    val_gen_seed = cfg.seed + 12345
    stop = "max_iters"
    best_state, best_val, start = None, np.inf, 0
    if resume is not None and resume["stage_state"] is not None:
        st = resume["stage_state"]
        opt.load_state_dict(st["opt"])
        gen.set_state(st["gen"])
        best_state, best_val, start = st["best_state"], float(st["best_val"]), resume["step"]
    for step in bar(range(start + 1, cfg.uv_iters + 1), desc="UV MLPs",
                    disable=not progress or None):
        loss, parts = _uv_loss(fwd, bwd, train_uv[order(step - 1)], cfg, gen)
        opt.zero_grad()
        loss.backward()
        opt.step()
        hist["uv_total"].append(float(loss.detach()))
        for k, p in zip(("cycle", "iso", "angle", "area"), parts, strict=True):
            hist[k].append(float(p.detach()))
        if step % eval_every == 0 or step == cfg.uv_iters:
            vg = torch.Generator().manual_seed(val_gen_seed)  # same pairs at every evaluation
            with torch.no_grad():
                v = float(np.mean([float(_uv_loss(fwd, bwd, u, cfg, vg)[0]) for u in val_uv]))
            hist["val_uv"].append([step, v])
            if on_eval:
                on_eval("uv", step, v)
            if v < best_val:
                best_val = v
                best_state = ({k: t.clone() for k, t in fwd.state_dict().items()},
                              {k: t.clone() for k, t in bwd.state_dict().items()})
            if converged(hist["val_uv"], tol, min_window=max(len(train_uv), MIN_WINDOW_STEPS)):
                stop = "converged"
                break
            if ck is not None and ck.due():
                snapshot("uv", step, {"opt": opt.state_dict(), "best_state": best_state,
                                      "best_val": best_val, "gen": gen.get_state()})
        if time.perf_counter() > deadline:
            stop = "budget"
            break
    if best_state is not None:
        fwd.load_state_dict(best_state[0])
        bwd.load_state_dict(best_state[1])
    return stop
