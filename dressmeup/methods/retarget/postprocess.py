"""Post-processes chained after any retargeting method (``"<method>+detail+penetration"``)."""

from __future__ import annotations

import numpy as np

from dressmeup.cache import hash_arrays
from dressmeup.methods.retarget.base import RetargetMethod, body_context, check_garment
from dressmeup.methods.retarget.detail import DetailTransfer
from dressmeup.methods.retarget.penetration import resolve_penetration

__all__ = ["DetailPost", "PenetrationPost", "Pipeline"]

_DETAIL_MEMO: dict = {}


class DetailPost(RetargetMethod):
    """``detail``: Laplacian detail transfer from the input garment (thesis 4.3.3.2).

    Parameters
    ----------
    laplacian : {"uniform", "cotan"}
        Thesis: uniform; demo: cotangent.
    anchor_fraction : float
        Share of vertices pinned to the retargeted garment (demo: 0.3).
    anchor_weight : float
    seed : int
    """

    name = "detail"

    def __init__(self, laplacian: str = "uniform", anchor_fraction: float = 0.3, anchor_weight: float = 1.0,
                 seed: int = 0) -> None:
        self.laplacian = laplacian
        self.anchor_fraction = anchor_fraction
        self.anchor_weight = anchor_weight
        self.seed = seed

    def transfer(self, garment_V, garment_F):
        """The factorised :class:`~dressmeup.methods.retarget.detail.DetailTransfer` of a garment
        (memoised per garment content and settings: a new target costs a back-substitution)."""

        key = hash_arrays(np.asarray(garment_V, dtype=np.float64), np.asarray(garment_F, dtype=np.int64),
                          extra=f"{self.laplacian}|{self.anchor_fraction}|{self.anchor_weight}|{self.seed}")
        if key not in _DETAIL_MEMO:
            if len(_DETAIL_MEMO) >= 8:
                _DETAIL_MEMO.pop(next(iter(_DETAIL_MEMO)))
            _DETAIL_MEMO[key] = DetailTransfer(garment_V, garment_F, laplacian=self.laplacian,
                                               anchor_fraction=self.anchor_fraction,
                                               anchor_weight=self.anchor_weight, seed=self.seed)
        return _DETAIL_MEMO[key]

    def apply(self, garment_V, garment_F, retargeted_V, source, target, body_model) -> np.ndarray:
        """Return the detailed (n, 3) float64 garment."""
        return self.transfer(garment_V, garment_F).apply(retargeted_V)


class PenetrationPost(RetargetMethod):
    """``penetration``: push garment vertices inside the target body outside (TailorNet-style).

    Parameters
    ----------
    margin : float
        Metres outside the skin (demo: 0.02).
    inside_weight : float
        Anchor weight of penetrating vertices (demo: 2).
    iterations : int
        Maximum number of solves.
    faces : bool
        Also push out faces whose centroid is inside (what IR counts).
    project : bool
        Finally move whatever is still inside straight to its target.
        ``faces=False, project=False`` is the first release's post-process.
    """

    name = "penetration"

    def __init__(self, margin: float = 0.005, inside_weight: float = 2.0, iterations: int = 3,
                 faces: bool = True, project: bool = True) -> None:
        self.margin = margin
        self.inside_weight = inside_weight
        self.iterations = iterations
        self.faces = faces
        self.project = project

    def apply(self, garment_V, garment_F, retargeted_V, source, target, body_model) -> np.ndarray:
        """Return the (n, 3) float64 garment with penetrations resolved."""

        t = body_context(body_model, target)
        return resolve_penetration(retargeted_V, garment_F, t.skin_vertices, t.skin_faces, margin=self.margin,
                                   inside_weight=self.inside_weight, iterations=self.iterations,
                                   faces=self.faces, project=self.project)


class Pipeline(RetargetMethod):
    """A retargeting method followed by post-processes, applied in order.

    Parameters
    ----------
    method : RetargetMethod
    post : list of DetailPost / PenetrationPost
    """

    def __init__(self, method: RetargetMethod, post: list) -> None:
        self.method = method
        self.post = post

    @property
    def name(self) -> str:  # type: ignore[override]
        """``"<method>+<post>+..."``."""
        return "+".join([self.method.name] + [p.name for p in self.post])

    def retarget(self, garment_V, garment_F, source, target, body_model) -> np.ndarray:
        """Run the method, then each post-process; returns (n, 3) float64."""
        V, F = check_garment(garment_V, garment_F)
        out = self.method.retarget(V, F, source, target, body_model)
        for p in self.post:
            out = p.apply(V, F, out, source, target, body_model)
        return out

    def __getattr__(self, item):
        # ``fit``/``save``/``load``, fitted attributes (``loss_history_``, ``last_timing_``) and
        # ``WEIGHTS`` of the base method; absent when the base method lacks them, so that
        # ``hasattr(pipeline, "fit")`` tells whether the chain is trainable.
        method = self.__dict__.get("method")
        if method is None or item.startswith("__") or not (item.endswith("_") or item in ("fit", "save")):
            raise AttributeError(item)
        attr = getattr(method, item)
        if item == "fit":
            def fit(*args, **kwargs):
                attr(*args, **kwargs)
                return self
            return fit
        return attr
