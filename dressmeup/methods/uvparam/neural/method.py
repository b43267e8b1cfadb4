"""The ``neural`` UV method: train per object on a decimated copy, infer on the full mesh."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.geometry.mesh import as_arrays
from dressmeup.methods.uvparam.base import UVResult

__all__ = ["NeuralMethod", "decimate_for_training"]


def decimate_for_training(V: np.ndarray, F: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """Edge-collapse decimation (libigl) to about ``n_vertices``; the mesh itself if already small.

    Returns
    -------
    V : (n2, 3) float64
    F : (m2, 3) int64
    """
    import igl

    if len(V) <= 1.5 * n_vertices:
        return V, F
    target_faces = int(2 * n_vertices * len(F) / max(2 * len(V), 1))
    out = igl.decimate(np.ascontiguousarray(V), np.ascontiguousarray(F, dtype=np.int64), max(target_faces, 64))
    V2, F2 = np.asarray(out[1], dtype=np.float64), np.asarray(out[2], dtype=np.int64)
    if len(F2) == 0:
        return V, F
    used = np.unique(F2)
    remap = np.full(len(V2), -1, dtype=np.int64)
    remap[used] = np.arange(len(used))
    return V2[used], remap[F2]


class NeuralMethod:
    """The thesis' self-supervised parameterisation (PatchNet + UV MLPs, xatlas packing).

    Parameters
    ----------
    config : {"fast", "reference"}
        Network sizes and training lengths (see ``neural.train.CONFIGS``).
    checkpoint : str or Path, optional
        A trained model: infer only (the discretisation-agnostic use). Without it,
        :meth:`parameterize` trains on a decimated copy of the mesh first (time included).
    use_operator_cache : bool
        Reuse cached DiffusionNet operators.
    save_checkpoint : str or Path, optional
        Where to save the model trained by :meth:`parameterize`.
    progress : bool
    **overrides
        Fields of :class:`~dressmeup.methods.uvparam.neural.train.NeuralConfig`
        (``n_patches``, ``uv_iters``, ``weights``, ``seed``, ...).
    """

    name = "neural"

    def __init__(self, config: str = "fast", checkpoint: str | Path | None = None,
                 use_operator_cache: bool = True, save_checkpoint: str | Path | None = None,
                 progress: bool = False, **overrides: Any):
        self.config = config
        self.checkpoint = checkpoint
        self.use_operator_cache = use_operator_cache
        self.save_checkpoint = save_checkpoint
        self.progress = progress
        self.overrides = overrides

    def parameterize(self, V, F) -> UVResult:
        """Parameterise a mesh (train-then-infer, or infer from ``checkpoint``).

        Parameters
        ----------
        V : (n, 3) float array
        F : (m, 3) int array

        Returns
        -------
        UVResult
        """
        from dressmeup.methods.uvparam.neural.infer import infer
        from dressmeup.methods.uvparam.neural.train import get_config, load_model, save_model, train

        t0 = time.perf_counter()
        V, F = as_arrays(V, F)
        info: dict = {}
        if self.checkpoint is not None:
            model = load_model(self.checkpoint)
        else:
            cfg = get_config(self.config, **self.overrides)
            Vt, Ft = decimate_for_training(V, F, cfg.train_vertices)
            model = train(Vt, Ft, cfg, progress=self.progress)
            info["seconds_train"] = time.perf_counter() - t0
            info["train_vertices"] = len(Vt)
            if self.save_checkpoint:
                save_model(model, self.save_checkpoint)
        res = infer(model, V, F, use_operator_cache=self.use_operator_cache)
        res.info.update(info)
        res.seconds = time.perf_counter() - t0
        return res
