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

from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_write_bytes
from dressmeup.methods.nn.checkpoint import load_checkpoint
from dressmeup.methods.nn.convergence import converged
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
                  checkpoint_every: int = 50, callback=None, until_converged: bool = False,
                  tol: float = 0.01):
    """Train ``method``'s network on prepared samples; see the module docstring.

    Parameters
    ----------
    method : IsomapRefine (or a subclass): supplies ``new_network()``, ``loss(net, sample)``,
        ``features(sample)`` and ``config.lr``, ``config.seed``.
    samples : list of RefineSample (training split).
    val_samples : list of RefineSample (validation split), optional.
    steps : int, total steps (a resumed run continues up to this count); with
        ``until_converged`` the most steps.
    wall_seconds : float, optional wall budget of this invocation (a resumed run goes on).
    until_converged : stop when the validation figure (ED with ground truth, else the loss)
        has improved by less than ``tol`` over the last 20 % of the steps, and over at least
        one pass over ``samples`` (:func:`dressmeup.methods.nn.convergence.converged`);
        ``stopped_by`` says ``converged``. Needs validation samples.
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
    if until_converged and not val_samples:
        raise ValueError("until_converged: give validation samples (the rule watches them)")
    net = method.new_network()
    run = _Run(method, net, torch.optim.Adam(net.parameters(), lr=float(method.config.lr)),
               Path(checkpoint) if checkpoint else None, val_samples)
    start = run.resume()
    history = run.history
    rng = np.random.default_rng(int(method.config.seed))
    n_epochs = int(steps) // len(samples) + 1
    order = np.concatenate([rng.permutation(len(samples)) for _ in range(n_epochs)])
    run.start_clock()
    net.train()
    step = start
    history.stopped_by = "steps"
    for step in progress(range(start, int(steps)), desc=f"training {method.name}", total=int(steps) - start):
        if val_samples and step % int(val_every) == 0 and not any(v[0] == step for v in history.val):
            run.validate(step)
        total, terms = method.loss(net, samples[order[step]])
        run.opt.zero_grad()
        total.backward()
        run.opt.step()
        history.train.append((step, float(total.detach()), terms))
        if callback is not None:
            callback(step, float(total.detach()), terms)
        run.tick()
        if (step + 1) % int(checkpoint_every) == 0:
            run.save(step + 1)
        if wall_seconds is not None and time.perf_counter() - run.t_wall > float(wall_seconds):
            history.stopped_by = "wall budget"
            step += 1
            break
        if until_converged and val_samples and (step + 1) % int(val_every) == 0:
            run.validate(step + 1)
            figure = [(s_, e if np.isfinite(e) else lo) for s_, lo, e in history.val]
            if converged(figure, tol, min_window=len(samples)):
                history.stopped_by = "converged"
                step += 1
                break
    else:
        step = int(steps)
    run.finish(step)
    return net, history


@dataclass
class _Run:
    """The state of one training run: the network and its optimiser, the history, the best
    weights on the validation samples so far, the checkpoint they go to, the clocks."""

    method: Any
    net: Any
    opt: Any
    ckpt_path: Path | None
    val_samples: list
    history: TrainHistory = field(default_factory=TrainHistory)
    best_state: dict | None = None
    best_score: float = np.inf
    t_wall: float = 0.0
    t_cpu: float = 0.0
    wall0: float = 0.0
    cpu0: float = 0.0

    def resume(self) -> int:
        """Load the checkpoint when it exists; the step to go on from (0 without one)."""
        if self.ckpt_path is None or not self.ckpt_path.is_file():
            return 0
        ck = load_checkpoint(self.ckpt_path, "training checkpoint", _CKPT_FORMAT,
                             ("network", "optimizer", "step", "history"))
        try:
            self.net.load_state_dict(ck["network"])
            self.opt.load_state_dict(ck["optimizer"])
            start = int(ck["step"])
            self.history = TrainHistory.from_dict(ck["history"])
        except (RuntimeError, ValueError, TypeError, KeyError) as exc:
            raise InputError(f"training checkpoint {self.ckpt_path}: it does not fit this run's "
                             f"network ({str(exc).splitlines()[0][:200]}); delete it to start "
                             "over") from exc
        self.best_state, self.best_score = ck["best_state"], float(ck["best_score"])
        log.info("resumed %s at step %d", self.ckpt_path, start)
        return start

    def start_clock(self) -> None:
        """Start timing this invocation (a resumed run adds to its history's seconds)."""
        self.t_wall, self.t_cpu = time.perf_counter(), time.process_time()
        self.wall0, self.cpu0 = self.history.wall_seconds, self.history.cpu_seconds

    def tick(self) -> None:
        """Wall and CPU seconds so far into the history."""
        self.history.wall_seconds = self.wall0 + time.perf_counter() - self.t_wall
        self.history.cpu_seconds = self.cpu0 + time.process_time() - self.t_cpu

    def save(self, step: int) -> None:
        """Write the whole state at ``step`` to the checkpoint (atomically), if there is one."""
        if self.ckpt_path is None:
            return
        self.ckpt_path.parent.mkdir(parents=True, exist_ok=True)
        atomic_write_bytes(self.ckpt_path, _state_bytes({
            "format": _CKPT_FORMAT, "network": self.net.state_dict(),
            "optimizer": self.opt.state_dict(), "step": step, "history": self.history.as_dict(),
            "best_state": self.best_state, "best_score": self.best_score}))

    def validate(self, step: int) -> None:
        """Score the network on the validation samples; keep its weights when best so far
        (ED with ground truth, else the loss)."""
        loss, ed = validate(self.method, self.net, self.val_samples)
        self.history.val.append((step, loss, ed))
        score = ed if np.isfinite(ed) else loss
        if np.isfinite(score) and score < self.best_score:
            self.best_score = score
            self.best_state = {k: v.detach().clone() for k, v in self.net.state_dict().items()}
            self.history.best_step = step

    def finish(self, step: int) -> None:
        """Last validation, times and checkpoint; the best weights kept (eval mode)."""
        if self.val_samples and not any(v[0] == step for v in self.history.val):
            self.validate(step)
        self.tick()
        self.save(step)
        if self.best_state is not None:
            self.net.load_state_dict(self.best_state)
        else:
            self.history.best_step = step
        self.net.eval()


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
