"""Body parameter files (docs/spec.md section 2): one ``.npz`` of plain arrays per body.

Fields: ``model`` (e.g. ``anny``, ``procedural``, ``smpl``, ``smplx``), ``gender``,
``shape`` (betas or phenotype vector), ``pose`` (axis-angle per joint, model's joint order),
``transl`` (3,), ``scale`` (scalar). Convention used everywhere:
``vertices = scale * model(shape, pose) + transl``.
Files are written atomically and read with ``allow_pickle=False``.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from dressmeup.errors import InputError
from dressmeup.io.atomic import atomic_path
from dressmeup.io.npz import load_npz

FIELDS = ("model", "gender", "shape", "pose", "transl", "scale")


def _float_array(value, name: str, ndim: int, last: int | None = None) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"body parameter {name!r}: expected numbers, got {type(value).__name__}") from exc
    if arr.ndim != ndim or (last is not None and arr.shape[-1] != last):
        want = {1: f"({last if last else 's'},)", 2: f"(j, {last})"}[ndim]
        raise InputError(f"body parameter {name!r}: expected shape {want}, got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"body parameter {name!r}: contains NaN or infinite values")
    return arr


@dataclass
class BodyParams:
    """Parameters of one body under one body model.

    Attributes
    ----------
    model : name of the body model (``get_body_model(model)``).
    gender : ``"neutral"``, ``"female"`` or ``"male"`` (SMPL family: picks the model file;
        open models keep gender in ``shape[0]`` and store ``"neutral"`` here).
    shape : (s,) float64 betas or phenotype vector.
    pose : (j, 3) float64 axis-angle per joint, each relative to its parent; ``pose[0]`` is
        the global orientation.
    transl : (3,) float64 translation in metres, applied after ``scale``.
    scale : float, uniform scale about the model origin.
    """

    model: str
    shape: np.ndarray
    pose: np.ndarray
    transl: np.ndarray = field(default_factory=lambda: np.zeros(3))
    scale: float = 1.0
    gender: str = "neutral"

    def __post_init__(self) -> None:
        if not isinstance(self.model, str) or not self.model:
            raise InputError(f"body parameter 'model': expected a non-empty string, got {self.model!r}")
        if not isinstance(self.gender, str):
            raise InputError(f"body parameter 'gender': expected a string, got {self.gender!r}")
        self.shape = _float_array(self.shape, "shape", 1)
        pose = np.asarray(self.pose, dtype=np.float64) if not isinstance(self.pose, np.ndarray) else self.pose
        if pose.ndim == 1 and pose.size % 3 == 0:
            pose = pose.reshape(-1, 3)
        self.pose = _float_array(pose, "pose", 2, 3)
        self.transl = _float_array(self.transl, "transl", 1, 3)
        try:
            scale = float(np.asarray(self.scale, dtype=np.float64).reshape(()))
        except (TypeError, ValueError) as exc:
            raise InputError(f"body parameter 'scale': expected one number, got {self.scale!r}") from exc
        if not np.isfinite(scale) or scale <= 0:
            raise InputError(f"body parameter 'scale': expected a positive number, got {scale}")
        self.scale = scale

    # ------------------------------------------------------------------ files
    def save(self, path: str | os.PathLike) -> Path:
        """Write the parameters to ``path`` (``.npz``, plain arrays, atomic); return the path."""

        path = Path(path)
        if path.suffix != ".npz":
            path = path.with_suffix(path.suffix + ".npz") if path.suffix else path.with_suffix(".npz")
        with atomic_path(path) as tmp, open(tmp, "wb") as fh:
            np.savez(
                fh,
                model=np.array(self.model),
                gender=np.array(self.gender),
                shape=self.shape,
                pose=self.pose,
                transl=self.transl,
                scale=np.array(self.scale, dtype=np.float64),
            )
        return path

    @classmethod
    def load(cls, path: str | os.PathLike) -> BodyParams:
        """Read parameters written by :meth:`save` (no pickle is ever loaded).

        Raises
        ------
        FileNotFoundError : the file does not exist.
        InputError : a field is missing or has the wrong shape (the message names it).
        """

        path = Path(path)
        if not path.is_file() and not path.exists():
            raise FileNotFoundError(f"body parameter file not found: {path}")
        arrays = load_npz(path, what="body parameter file", max_bytes=64 << 20)
        missing = [k for k in ("model", "shape", "pose") if k not in arrays]
        if missing:
            raise InputError(f"{path}: missing field(s) {missing}; expected fields {list(FIELDS)}")
        try:
            return cls(
                model=str(arrays["model"]),
                gender=str(arrays.get("gender", "neutral")),
                shape=arrays["shape"],
                pose=arrays["pose"],
                transl=arrays.get("transl", np.zeros(3)),
                scale=arrays.get("scale", 1.0),
            )
        except InputError as exc:
            raise InputError(f"{path}: {exc}") from exc

    # -------------------------------------------------------------- helpers
    def check_model(self, model) -> None:
        """Raise ``InputError`` unless the field shapes fit ``model`` (a BodyModel)."""
        if self.model != model.name:
            raise InputError(f"body parameters are for model {self.model!r}, not {model.name!r}")
        j = len(model.joint_names)
        if self.pose.shape != (j, 3):
            raise InputError(f"body parameter 'pose': expected shape ({j}, 3) for model "
                             f"{model.name!r}, got {self.pose.shape}")
        if self.shape.shape[0] > model.shape_dim:
            raise InputError(f"body parameter 'shape': model {model.name!r} takes at most "
                             f"{model.shape_dim} values, got {self.shape.shape[0]}")

    def copy(self) -> BodyParams:
        """Return a deep copy."""
        return BodyParams(model=self.model, gender=self.gender, shape=self.shape.copy(),
                          pose=self.pose.copy(), transl=self.transl.copy(), scale=self.scale)
