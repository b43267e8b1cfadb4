"""Shared pieces of the retargeting methods: the method base class and the posed-body context.

A method is estimator-like (scikit-learn): hyperparameters are keyword arguments stored as
attributes by ``__init__`` and nothing else happens there; ``retarget`` does the work:

    method.retarget(garment_V (n, 3), garment_F (m, 3), source: BodyParams,
                    target: BodyParams, body_model) -> (n, 3) float64

keeping the garment's topology.
"""

from __future__ import annotations

import inspect
from dataclasses import dataclass
from typing import Any

import numpy as np

from dressmeup.geometry.mesh import as_arrays, vertex_normals

__all__ = ["RetargetMethod", "BodyContext", "body_context", "skin_of", "check_garment"]


class RetargetMethod:
    """Base class: ``get_params``/``set_params`` over the ``__init__`` keyword arguments."""

    name = "base"

    def get_params(self) -> dict[str, Any]:
        """The hyperparameters (the ``__init__`` keyword arguments) as a dict."""
        sig = inspect.signature(type(self).__init__)
        return {p: getattr(self, p) for p in sig.parameters if p != "self"}

    def set_params(self, **params: Any) -> RetargetMethod:
        """Set hyperparameters by name; unknown names raise ``ValueError``."""
        valid = self.get_params()
        for k, v in params.items():
            if k not in valid:
                raise ValueError(f"{self.name}: unknown hyperparameter {k!r}; known: {sorted(valid)}")
            setattr(self, k, v)
        return self

    def __repr__(self) -> str:
        args = ", ".join(f"{k}={v!r}" for k, v in self.get_params().items())
        return f"{type(self).__name__}({args})"

    def retarget(self, garment_V, garment_F, source, target, body_model) -> np.ndarray:  # pragma: no cover
        raise NotImplementedError


def skin_of(body_model) -> tuple[np.ndarray, np.ndarray]:
    """Skin (largest connected component) of a body model: ``(vertex_ids (s,), faces (f, 3))``.

    The body model's own :meth:`~dressmeup.body.base.LBSBodyModel.skin` (kept on the model).
    """
    return body_model.skin()


@dataclass
class BodyContext:
    """One posed body in world coordinates, with what the methods need from it.

    Attributes
    ----------
    vertices : (b, 3) float64 posed vertices (``scale * model + transl``).
    faces : (f, 3) int64 all faces of the model.
    skin_ids : (s,) int64 skin vertex indices; skin_faces : (g, 3) int64 faces over them.
    joints : (j, 3) float64 posed joints (world); transforms : (j, 4, 4) LBS matrices
        (before scale/translation); rest_vertices : (b, 3) shaped rest pose.
    scale : float; transl : (3,) float64.
    """

    vertices: np.ndarray
    faces: np.ndarray
    skin_ids: np.ndarray
    skin_faces: np.ndarray
    joints: np.ndarray
    transforms: np.ndarray
    rest_vertices: np.ndarray
    scale: float
    transl: np.ndarray

    @property
    def skin_vertices(self) -> np.ndarray:
        """(s, 3) float64 posed skin vertices."""
        return self.vertices[self.skin_ids]

    def skin_normals(self) -> np.ndarray:
        """(s, 3) float64 area-weighted unit normals of the posed skin."""
        return vertex_normals(self.skin_vertices, self.skin_faces)


def body_context(body_model, params) -> BodyContext:
    """Pose ``body_model`` with ``params`` (:class:`dressmeup.body.BodyParams`)."""
    out = body_model.posed(params)
    ids, faces = skin_of(body_model)
    return BodyContext(vertices=np.asarray(out.vertices, dtype=np.float64), faces=np.asarray(body_model.faces),
                       skin_ids=ids, skin_faces=faces, joints=np.asarray(out.joints, dtype=np.float64),
                       transforms=np.asarray(out.transforms, dtype=np.float64),
                       rest_vertices=np.asarray(out.rest_vertices, dtype=np.float64),
                       scale=float(params.scale), transl=np.asarray(params.transl, dtype=np.float64))


def check_garment(garment_V, garment_F) -> tuple[np.ndarray, np.ndarray]:
    """Validate the garment arrays (``ValueError`` naming ``garment``)."""
    return as_arrays(garment_V, garment_F, name="garment")
