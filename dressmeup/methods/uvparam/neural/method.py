"""The ``neural`` UV method: a shipped pretrained model (``pretrained=``), a checkpoint, or
training per object on a decimated copy; inference on the full mesh.

Shipped models (``dressmeup/methods/uvparam/weights/neural_<name>.pt``, float16): one per
garment category (``topwear``, ``bottomwear``, ``dress``) and ``general``; see
docs/uvparam.md for how they were trained and their sizes. ``pretrained="category"`` picks
the model of the mesh's category (passed to :meth:`NeuralMethod.parameterize`) and falls back
to ``general``.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from dressmeup.errors import InputError
from dressmeup.geometry.mesh import as_arrays
from dressmeup.geometry.simplify import decimate
from dressmeup.methods.uvparam.base import UVResult

__all__ = ["NeuralMethod", "PRETRAINED", "pretrained_path"]

#: names of the shipped pretrained models
PRETRAINED = ("topwear", "bottomwear", "dress", "general")
WEIGHTS_DIR = Path(__file__).resolve().parents[1] / "weights"


def pretrained_path(name: str) -> Path:
    """Path of a shipped pretrained model.

    Raises
    ------
    InputError
        Unknown name, or the weights are not installed.
    """

    if name not in PRETRAINED:
        raise InputError(f"pretrained: expected one of {', '.join(PRETRAINED)} or 'category', "
                         f"got {name!r}")
    path = WEIGHTS_DIR / f"neural_{name}.pt"
    if not path.is_file():
        raise InputError(f"pretrained neural UV model {name!r} is not installed ({path} is "
                         "missing): reinstall dressmeup, or train one with "
                         "benchmarks/train_uvparam_pretrained.py")
    return path


class NeuralMethod:
    """The thesis' self-supervised parameterisation (PatchNet + UV MLPs, xatlas packing).

    Parameters
    ----------
    config : {"fast", "reference"}
        Network sizes and training lengths (see ``neural.model.CONFIGS``).
    checkpoint : str or Path, optional
        A trained model: infer only (the discretisation-agnostic use). Without it (and
        without ``pretrained``), :meth:`parameterize` trains on a decimated copy of the mesh
        first (time included).
    pretrained : {"topwear", "bottomwear", "dress", "general", "category"}, optional
        Use a shipped model (infer only); ``"category"`` chooses by the mesh's category.
    use_operator_cache : bool
        Reuse cached DiffusionNet operators.
    save_checkpoint : str or Path, optional
        Where to save the model trained by :meth:`parameterize`.
    progress : bool
    **overrides
        Fields of :class:`~dressmeup.methods.uvparam.neural.model.NeuralConfig`
        (``n_patches``, ``uv_iters``, ``weights``, ``seed``, ...).
    """

    name = "neural"

    def __init__(self, config: str = "fast", checkpoint: str | Path | None = None,
                 use_operator_cache: bool = True, save_checkpoint: str | Path | None = None,
                 progress: bool = False, pretrained: str | None = None, **overrides: Any):
        if pretrained is not None and checkpoint is not None:
            raise InputError("neural: give either pretrained= or checkpoint=, not both")
        if pretrained is not None and pretrained != "category":
            pretrained_path(pretrained)  # fail early on an unknown or missing model
        self.pretrained = pretrained
        self._models: dict = {}
        self.config = config
        self.checkpoint = checkpoint
        self.use_operator_cache = use_operator_cache
        self.save_checkpoint = save_checkpoint
        self.progress = progress
        self.overrides = overrides

    def _load(self, path: Path):
        # heavy: scipy.sparse
        from dressmeup.methods.uvparam.neural.model import load_model

        key = str(path)
        if key not in self._models:
            self._models[key] = load_model(path)
        return self._models[key]

    def parameterize(self, V, F, category: str | None = None) -> UVResult:
        """Parameterise a mesh (infer with a pretrained model or checkpoint, or train then infer).

        Parameters
        ----------
        V : (n, 3) float array
        F : (m, 3) int array
        category : str, optional
            The mesh's category (``topwear``, ...), used by ``pretrained="category"``.

        Returns
        -------
        UVResult
            ``info["track"]`` is ``"pretrained"`` when a model trained on other meshes was
            applied (the mesh's hash is not among the model's training meshes), otherwise
            ``"per-mesh"``; ``info["model"]`` names the model used.
        """
        # heavy: scipy.linalg, scipy.sparse
        from dressmeup.methods.uvparam.neural.infer import infer
        from dressmeup.methods.uvparam.neural.model import get_config, save_model
        from dressmeup.methods.uvparam.neural.train import train
        from dressmeup.methods.uvparam.neural.train_set import mesh_sha

        t0 = time.perf_counter()
        V, F = as_arrays(V, F)
        info: dict = {}
        if self.pretrained is not None or self.checkpoint is not None:
            if self.pretrained is not None:
                name = self.pretrained
                if name == "category":
                    name = category if category in PRETRAINED else "general"
                path = pretrained_path(name)
                info["model"] = name
            else:
                path = Path(self.checkpoint)
                info["model"] = str(path)
            model = self._load(path)
            seen = set(model.history.get("train_mesh_sha", []))
            # a checkpoint without training hashes (per-object training) was fit to some mesh:
            # only models that list their training meshes can claim the pretrained track
            info["track"] = "pretrained" if seen and mesh_sha(V, F) not in seen else "per-mesh"
        else:
            info["track"] = "per-mesh"
            cfg = get_config(self.config, **self.overrides)
            Vt, Ft = decimate(V, F, cfg.train_vertices)
            model = train(Vt, Ft, cfg, progress=self.progress)
            info["seconds_train"] = time.perf_counter() - t0
            info["train_vertices"] = len(Vt)
            if self.save_checkpoint:
                save_model(model, self.save_checkpoint)
        res = infer(model, V, F, use_operator_cache=self.use_operator_cache)
        res.info.update(info)
        res.seconds = time.perf_counter() - t0
        return res
