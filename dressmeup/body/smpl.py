"""SMPL, SMPL-H and SMPL-X from the user's own model files, with our own LBS.

The model files are licensed by their authors and never downloaded by dressmeup: register
on the model's website, accept its licence, download the files and put them in a folder
(see :func:`find_model_file` for the names looked for). Pickles are read with the
restricted unpickler of :mod:`dressmeup.body.safe_pickle` (no code can run, chumpy is not
needed); ``.npz`` files are read with ``allow_pickle=False``.

Model: ``v = LBS(v_template + shapedirs @ betas + posedirs @ (R[1:] - I), weights, A)``,
joints regressed from the shaped template (``J_regressor``), the standard SMPL formulation.
SMPL-X expression and hand PCA are not used (hands are posed with full axis-angle per joint).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from dressmeup.body.base import LBSBodyModel
from dressmeup.body.safe_pickle import safe_load_pickle
from dressmeup.body.skeleton import SMPL22_JOINT_NAMES
from dressmeup.errors import InputError, MissingModelError

ENV_VAR = "DRESSMEUP_SMPL_DIR"

WEBSITES = {
    "smpl": "https://smpl.is.tue.mpg.de",
    "smplh": "https://mano.is.tue.mpg.de",
    "smplx": "https://smpl-x.is.tue.mpg.de",
}
_PREFIX = {"smpl": "SMPL", "smplh": "SMPLH", "smplx": "SMPLX"}

_HAND = [f"{f}{k}" for f in ("index", "middle", "pinky", "ring", "thumb") for k in (1, 2, 3)]
JOINT_NAMES = {
    "smpl": SMPL22_JOINT_NAMES + ("left_hand", "right_hand"),
    "smplh": SMPL22_JOINT_NAMES + tuple(f"left_{h}" for h in _HAND)
    + tuple(f"right_{h}" for h in _HAND),
    "smplx": SMPL22_JOINT_NAMES + ("jaw", "left_eye_smplhf", "right_eye_smplhf")
    + tuple(f"left_{h}" for h in _HAND) + tuple(f"right_{h}" for h in _HAND),
}


def default_model_dir() -> Path:
    """Folder searched for model files: ``$DRESSMEUP_SMPL_DIR`` or ``~/.dressmeup/models``."""
    env = os.environ.get(ENV_VAR)
    return Path(env) if env else Path.home() / ".dressmeup" / "models"


def expected_file_names(family: str, gender: str) -> list[str]:
    """File names accepted for ``family`` (smpl/smplh/smplx) and ``gender``."""
    p = _PREFIX[family]
    g = gender.upper()
    names = [f"{p}_{g}.npz", f"{p}_{g}.pkl"]
    if family == "smpl":
        short = {"NEUTRAL": "neutral", "FEMALE": "f", "MALE": "m"}[g]
        names += [f"basicModel_{gender.lower()}_lbs_10_207_0_v1.0.0.pkl",
                  f"basicmodel_{short}_lbs_10_207_0_v1.1.0.pkl"]
    if family == "smplh":
        names += [f"{gender.lower()}/model.npz"]
    return names


def find_model_file(family: str, gender: str = "neutral",
                    model_path: str | os.PathLike | None = None) -> Path:
    """Locate the model file of ``family``/``gender``.

    ``model_path`` may be the file itself or a folder; a folder is searched directly and in
    its ``<family>/`` sub-folder (the layout of the ``smplx`` package), for the names of
    :func:`expected_file_names`.

    Raises
    ------
    MissingModelError : nothing found; the message lists every path tried, the expected file
        names and where the files come from.
    """
    if family not in _PREFIX:
        raise ValueError(f"family: expected one of {sorted(_PREFIX)}, got {family!r}")
    if gender not in ("neutral", "female", "male"):
        raise ValueError(f"gender: expected 'neutral', 'female' or 'male', got {gender!r}")
    base = Path(model_path) if model_path is not None else default_model_dir()
    if base.is_file():
        return base
    names = expected_file_names(family, gender)
    tried = []
    for folder in (base, base / family):
        for name in names:
            candidate = folder / name
            tried.append(candidate)
            if candidate.is_file():
                return candidate
    raise MissingModelError(
        f"{family.upper()} model file not found. Looked for: "
        + ", ".join(str(t) for t in tried)
        + f". Expected one of {names} in {base} (or {base / family}); pass model_path=... or "
        f"set {ENV_VAR}. These files are not shipped with dressmeup: download them from "
        f"{WEBSITES[family]} after registering and accepting the model's licence."
    )


def _to_dense(x) -> np.ndarray:
    if hasattr(x, "toarray"):
        return np.asarray(x.toarray())
    return np.asarray(x)


def load_model_arrays(path: str | os.PathLike) -> dict[str, np.ndarray]:
    """Read the arrays of an SMPL-family model file (``.pkl`` safely, or ``.npz``).

    Returns
    -------
    dict with ``v_template (n,3)``, ``f (m,3)``, ``J_regressor (j,n)``, ``weights (n,j)``,
    ``kintree_table (2,j)``, ``shapedirs (n,3,s)``, ``posedirs (n,3,p)`` as plain arrays.

    Raises
    ------
    InputError : unsafe pickle, missing key or wrong shape (names the file and field).
    """

    path = Path(path)
    keys = ("v_template", "f", "J_regressor", "weights", "kintree_table", "shapedirs", "posedirs")
    if path.suffix == ".npz":
        try:
            with np.load(path, allow_pickle=False) as data:
                missing = [k for k in keys if k not in data.files]
                if missing:
                    raise InputError(f"{path}: missing field(s) {missing}")
                raw = {k: data[k] for k in keys}
        except ValueError as exc:
            if isinstance(exc, InputError):
                raise
            raise InputError(f"{path}: a needed field is not a plain array ({exc})") from exc
    else:
        obj = safe_load_pickle(path)
        if not isinstance(obj, dict):
            raise InputError(f"{path}: expected a dict of arrays, got {type(obj).__name__}")
        missing = [k for k in keys if k not in obj]
        if missing:
            raise InputError(f"{path}: missing field(s) {missing}")
        raw = {k: obj[k] for k in keys}
    out = {}
    for k in keys:
        try:
            out[k] = _to_dense(raw[k])
        except Exception as exc:
            raise InputError(f"{path}: field {k!r} is not an array") from exc
        if out[k].dtype == object:
            raise InputError(f"{path}: field {k!r} is not a numeric array")
    n = out["v_template"].shape[0]
    j = out["kintree_table"].shape[-1]
    checks = {
        "v_template": (n, 3), "J_regressor": (j, n), "weights": (n, j),
        "kintree_table": (2, j),
    }
    for k, shape in checks.items():
        if out[k].shape != shape:
            raise InputError(f"{path}: field {k!r} has shape {out[k].shape}, expected {shape}")
    if out["f"].ndim != 2 or out["f"].shape[1] != 3 or out["f"].max() >= n:
        raise InputError(f"{path}: field 'f' has shape {out['f'].shape}, expected (m, 3) < {n}")
    for k, last in (("shapedirs", None), ("posedirs", (j - 1) * 9)):
        a = out[k]
        if a.ndim == 2 and a.shape[0] == n * 3:
            a = a.reshape(n, 3, -1)
        if a.ndim != 3 or a.shape[:2] != (n, 3) or (last is not None and a.shape[2] != last):
            want = f"({n}, 3, {last if last else 's'})"
            raise InputError(f"{path}: field {k!r} has shape {out[k].shape}, expected {want}")
        out[k] = a
    return out


class SMPLBody(LBSBodyModel):
    """An SMPL-family model read from a user file.

    Parameters
    ----------
    gender : ``"neutral"``, ``"female"`` or ``"male"`` (picks the file).
    model_path : the model file or a folder holding it (default :func:`default_model_dir`).
    num_betas : number of shape coefficients used (at most those in the file).
    """

    family = "smpl"

    def __init__(self, gender: str = "neutral", model_path: str | os.PathLike | None = None,
                 num_betas: int = 10) -> None:
        path = find_model_file(self.family, gender, model_path)
        arrays = load_model_arrays(path)
        self.name = self.family
        self.gender = gender
        self.model_file = path
        self.template_vertices = arrays["v_template"].astype(np.float64)
        self.faces = arrays["f"].astype(np.int64)
        self.J_regressor = arrays["J_regressor"].astype(np.float64)
        self.skinning_weights = arrays["weights"].astype(np.float64)
        parents = arrays["kintree_table"][0].astype(np.int64)
        parents[0] = -1
        self.joint_parents = parents
        if any(parents[k] >= k for k in range(1, parents.size)):
            raise InputError(f"{path}: kintree_table parents must precede their children")
        j = parents.size
        names = JOINT_NAMES.get(self.family, ())
        self.joint_names = names if len(names) == j else tuple(f"joint_{k}" for k in range(j))
        s_avail = arrays["shapedirs"].shape[2]
        if num_betas < 1:
            raise ValueError(f"num_betas: expected >= 1, got {num_betas}")
        self.shape_dim = int(min(num_betas, s_avail))
        self.shapedirs = arrays["shapedirs"][:, :, : self.shape_dim].astype(np.float64)
        self.posedirs = arrays["posedirs"].astype(np.float64)
        self.default_shape = np.zeros(self.shape_dim)
        self.template_joints = self.J_regressor @ self.template_vertices

    def rest(self, shape):
        """Shaped template (b, n, 3) and regressed joints (b, j, 3)."""
        # heavy: torch (~1.1 s to import)
        import torch

        dt, dev = shape.dtype, shape.device
        V = self._buffer("template_vertices", dt, dev)[None] + torch.einsum(
            "bs,nks->bnk", shape, self._buffer("shapedirs", dt, dev))
        J = torch.einsum("jn,bnk->bjk", self._buffer("J_regressor", dt, dev), V)
        return V, J

    def pose_offsets(self, rotations):
        """Pose correctives ``posedirs @ (R[1:] - I)`` (b, n, 3)."""
        # heavy: torch (~1.1 s to import)
        import torch

        eye = torch.eye(3, dtype=rotations.dtype, device=rotations.device)
        feat = (rotations[:, 1:] - eye).reshape(rotations.shape[0], -1)
        return torch.einsum("nkp,bp->bnk", self._buffer("posedirs", rotations.dtype,
                                                        rotations.device), feat)


class SMPLHBody(SMPLBody):
    """SMPL-H (52 joints) from ``SMPLH_<GENDER>.npz/.pkl``."""

    family = "smplh"


class SMPLXBody(SMPLBody):
    """SMPL-X (55 joints) from ``SMPLX_<GENDER>.npz/.pkl`` (body shape betas only)."""

    family = "smplx"
