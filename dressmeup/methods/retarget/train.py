"""Training loop of the refinement networks: seeded, resumable, budgeted, validated.

:func:`train_network` runs Adam on prepared samples (one sample per step, a seeded
permutation per epoch) for ``steps`` steps or until ``wall_seconds`` have passed, whichever
comes first; every ``val_every`` steps it scores the network on the validation samples (the
training loss, and the ground-truth vertex error ED when the samples carry their ground
truth) and keeps the weights with the lowest validation ED (or loss): choosing the step is the
one hyperparameter chosen, on the validation split only. Every ``checkpoint_every`` steps the
whole state (network, optimiser, step, history, best weights) is written atomically to
``checkpoint``; a run given an existing checkpoint resumes from it.

The history (``TrainHistory``) holds the training loss of every step and the validation curve,
with wall and CPU seconds; :func:`plot_history` draws the learning curves.
"""

from __future__ import annotations

import io
import logging
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.io.atomic import atomic_write_bytes
from dressmeup.progress import progress

log = logging.getLogger(__name__)

__all__ = ["TrainHistory", "train_network", "validate", "plot_history"]

_CKPT_FORMAT = "dressmeup-retarget-training-v1"


@dataclass
class TrainHistory:
    """Learning curves of one training run.

    Attributes
    ----------
    train : list of (step, total loss, {term: value}) per step.
    val : list of (step, mean validation loss, mean validation ED in metres or nan).
    wall_seconds, cpu_seconds : float, time spent in training steps (resumed runs add up).
    stopped_by : "steps" or "wall budget".
    best_step : int, the step whose weights were kept (lowest validation ED, else loss).
    """

    train: list = field(default_factory=list)
    val: list = field(default_factory=list)
    wall_seconds: float = 0.0
    cpu_seconds: float = 0.0
    stopped_by: str = "steps"
    best_step: int = -1

    def as_dict(self) -> dict[str, Any]:
        """JSON-friendly form."""
        return {"train": [[s, t, terms] for s, t, terms in self.train],
                "val": [[s, lo, ed] for s, lo, ed in self.val], "wall_seconds": self.wall_seconds,
                "cpu_seconds": self.cpu_seconds, "stopped_by": self.stopped_by, "best_step": self.best_step}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> TrainHistory:
        """Inverse of :meth:`as_dict`."""
        return cls(train=[tuple(r) for r in d["train"]], val=[tuple(r) for r in d["val"]],
                   wall_seconds=float(d["wall_seconds"]), cpu_seconds=float(d["cpu_seconds"]),
                   stopped_by=str(d["stopped_by"]), best_step=int(d["best_step"]))


def validate(method, net, samples) -> tuple[float, float]:
    """Mean loss and mean ground-truth ED (metres; nan without ground truth) over ``samples``."""
    # heavy: torch (~1.1 s to import)
    import torch

    if not samples:
        return float("nan"), float("nan")
    losses, eds = [], []
    net.eval()
    with torch.no_grad():
        for s in samples:
            total, _ = method.loss(net, s)
            losses.append(float(total))
            if getattr(s, "truth", None) is not None:
                feats, gp, bp = method.features(s)
                v = s.x.astype(np.float64) + net(feats, gp, bp).cpu().numpy().astype(np.float64)
                eds.append(float(np.linalg.norm(v - s.truth, axis=1).mean()))
    net.train()
    return float(np.mean(losses)), float(np.mean(eds)) if eds else float("nan")


def _state_bytes(obj: Any) -> bytes:
    # heavy: torch (~1.1 s to import)
    import torch

    buf = io.BytesIO()
    torch.save(obj, buf)
    return buf.getvalue()


def train_network(method, samples: list, val_samples: list | None = None, steps: int = 300,
                  wall_seconds: float | None = None, val_every: int = 50, checkpoint: str | Path | None = None,
                  checkpoint_every: int = 50, callback=None):
    """Train ``method``'s network on prepared samples; see the module docstring.

    Parameters
    ----------
    method : IsomapRefine (or a subclass): supplies ``new_network()``, ``loss(net, sample)``,
        ``features(sample)``, ``lr`` and ``seed``.
    samples : list of RefineSample (training split).
    val_samples : list of RefineSample (validation split), optional.
    steps : int, total steps (a resumed run continues up to this count).
    wall_seconds : float, optional wall budget of this invocation.
    val_every, checkpoint_every : int, steps between validations / checkpoints.
    checkpoint : path, optional; resumed from when it exists.
    callback : callable(step, total, terms), optional.

    Returns
    -------
    (network with the kept weights, in eval mode; TrainHistory)
    """
    # heavy: torch (~1.1 s to import)
    import torch

    if not samples:
        raise ValueError("samples: expected at least one prepared training sample")
    val_samples = list(val_samples or [])
    net = method.new_network()
    opt = torch.optim.Adam(net.parameters(), lr=float(method.lr))
    history = TrainHistory()
    start = 0
    best_state, best_score = None, np.inf
    ckpt_path = Path(checkpoint) if checkpoint else None
    if ckpt_path is not None and ckpt_path.is_file():
        ck = torch.load(ckpt_path, map_location="cpu", weights_only=True)
        if not isinstance(ck, dict) or ck.get("format") != _CKPT_FORMAT:
            raise ValueError(f"{ckpt_path}: not a training checkpoint ({_CKPT_FORMAT})")
        net.load_state_dict(ck["network"])
        opt.load_state_dict(ck["optimizer"])
        start = int(ck["step"])
        history = TrainHistory.from_dict(ck["history"])
        best_state, best_score = ck["best_state"], float(ck["best_score"])
        log.info("resumed %s at step %d", ckpt_path, start)
    rng = np.random.default_rng(int(method.seed))
    n_epochs = int(steps) // len(samples) + 1
    order = np.concatenate([rng.permutation(len(samples)) for _ in range(n_epochs)])

    def save_checkpoint(step: int) -> None:
        if ckpt_path is None:
            return
        ckpt_path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_bytes(ckpt_path, _state_bytes({
            "format": _CKPT_FORMAT, "network": net.state_dict(), "optimizer": opt.state_dict(), "step": step,
            "history": history.as_dict(), "best_state": best_state, "best_score": best_score}))

    def run_validation(step: int) -> None:
        nonlocal best_state, best_score
        loss, ed = validate(method, net, val_samples)
        history.val.append((step, loss, ed))
        score = ed if np.isfinite(ed) else loss
        if np.isfinite(score) and score < best_score:
            best_score = score
            best_state = {k: v.detach().clone() for k, v in net.state_dict().items()}
            history.best_step = step

    t_wall, t_cpu = time.perf_counter(), time.process_time()
    wall0, cpu0 = history.wall_seconds, history.cpu_seconds
    net.train()
    step = start
    history.stopped_by = "steps"
    for step in progress(range(start, int(steps)), desc=f"training {method.name}", total=int(steps) - start):
        if val_samples and step % int(val_every) == 0 and not any(v[0] == step for v in history.val):
            run_validation(step)
        total, terms = method.loss(net, samples[order[step]])
        opt.zero_grad()
        total.backward()
        opt.step()
        history.train.append((step, float(total.detach()), terms))
        if callback is not None:
            callback(step, float(total.detach()), terms)
        history.wall_seconds = wall0 + time.perf_counter() - t_wall
        history.cpu_seconds = cpu0 + time.process_time() - t_cpu
        if (step + 1) % int(checkpoint_every) == 0:
            save_checkpoint(step + 1)
        if wall_seconds is not None and time.perf_counter() - t_wall > float(wall_seconds):
            history.stopped_by = "wall budget"
            step += 1
            break
    else:
        step = int(steps)
    if val_samples:
        run_validation(step)
    history.wall_seconds = wall0 + time.perf_counter() - t_wall
    history.cpu_seconds = cpu0 + time.process_time() - t_cpu
    save_checkpoint(step)
    if best_state is not None:
        net.load_state_dict(best_state)
    else:
        history.best_step = step
    net.eval()
    return net, history


def plot_history(history: TrainHistory, path: str | Path, title: str = "") -> Path:
    """Learning curves as a PNG: training loss (running mean of 20 steps) and validation ED/loss."""
    # heavy: matplotlib (~0.3 s to import)
    import matplotlib

    matplotlib.use("Agg")
    # heavy: matplotlib (~0.3 s to import)
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 3.6))
    if history.train:
        s = np.array([r[0] for r in history.train])
        t = np.array([r[1] for r in history.train])
        w = min(20, len(t))
        run = np.convolve(t, np.ones(w) / w, mode="valid")
        axes[0].plot(s, t, color="0.8", lw=0.6, label="per step")
        axes[0].plot(s[w - 1:], run, color="C0", label=f"running mean ({w})")
        axes[0].set_yscale("log")
    axes[0].set_xlabel("step")
    axes[0].set_ylabel("training loss")
    axes[0].legend(fontsize=8)
    if history.val:
        vs = np.array([r[0] for r in history.val])
        vl = np.array([r[1] for r in history.val])
        ve = np.array([r[2] for r in history.val])
        if np.isfinite(ve).any():
            axes[1].plot(vs, 1000 * ve, "o-", color="C1", label="validation ED [mm]")
            axes[1].set_ylabel("validation ED [mm]")
        else:
            axes[1].plot(vs, vl, "o-", color="C1", label="validation loss")
            axes[1].set_ylabel("validation loss")
        if history.best_step >= 0:
            axes[1].axvline(history.best_step, color="0.5", ls="--", lw=0.8, label=f"kept: step {history.best_step}")
        axes[1].legend(fontsize=8)
    axes[1].set_xlabel("step")
    fig.suptitle(title or "learning curves", fontsize=10)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    plt.close(fig)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(path, buf.getvalue())
    return path
