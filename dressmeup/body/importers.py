"""Importers: other tools' body parameters -> :class:`BodyParams` (docs/spec.md section 2).

Every importer returns parameters under our one convention
``vertices = scale * model(shape, pose) + transl`` with ``pose[0]`` the global orientation
about the root joint. Conversions (see docs/body-models.md):

- **EasyMocap** JSON (``Rh``, ``Th``, ``poses``, ``shapes``): EasyMocap poses the body
  with ``poses`` and then rotates the whole mesh about the model origin,
  ``v = R(Rh) M(shapes, poses) + Th``. Our root rotation pivots about the rest root joint
  ``J0`` (which depends on the shape), so ``pose[0] = log(R(Rh) R(poses[0]))`` and
  ``transl = R(Rh) J0 + Th - J0``; the body model is needed to compute ``J0``.
- **PAMIR** pickle (``betas``, ``body_pose`` (72), ``body_scale``,
  ``global_body_translation``): ``v = body_scale * SMPL(betas, body_pose) +
  global_body_translation``, i.e. ``scale = body_scale`` and ``transl =
  global_body_translation`` directly.
- **smplify-x / IPNet** style (``betas``, ``pose`` or ``global_orient`` + ``body_pose`` [+
  ``jaw_pose``, ``leye_pose``, ``reye_pose``, ``left_hand_pose``, ``right_hand_pose``],
  ``trans`` or ``transl``): ``v = model(betas, pose) + trans``: ``scale = 1``, ``transl =
  trans``. Hand poses must be full axis-angle (45 values); PCA hand coefficients are refused.

Pickles are read with the restricted unpickler (no code can run).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import numpy as np

from dressmeup.body.models import get_body_model
from dressmeup.body.params import BodyParams
from dressmeup.body.safe_pickle import safe_load_pickle
from dressmeup.errors import InputError
from dressmeup.io.jsonio import parse_json_file
from dressmeup.io.npz import load_npz

_IMPORTERS: dict[str, Callable[..., BodyParams]] = {}


def register_importer(name: str, func: Callable[..., BodyParams]) -> None:
    """Register ``func(path, body_model=None, **kw) -> BodyParams`` under ``name``."""
    _IMPORTERS[name] = func


def available_importers() -> list[str]:
    """Names accepted by :func:`import_body_params`."""
    return sorted(_IMPORTERS)


def _read_mapping(path: Path) -> dict:
    if not path.is_file():
        raise FileNotFoundError(f"body parameter file not found: {path}")
    suffix = path.suffix.lower()
    if suffix == ".json":
        data = parse_json_file(path)  # not UTF-8 / not JSON: InputError naming the file
    elif suffix == ".npz":
        data = load_npz(path, what="body parameter file")
    elif suffix in (".pkl", ".pickle"):
        data = safe_load_pickle(path)
    else:
        raise InputError(f"{path}: unsupported extension {suffix!r} (expected .json, .npz, .pkl)")
    return data


def _field(data: dict, names, path, required=True):
    for n in (names if isinstance(names, (list, tuple)) else [names]):
        if n in data and data[n] is not None:
            try:
                arr = np.asarray(data[n], dtype=np.float64)
            except (TypeError, ValueError) as exc:
                raise InputError(f"{path}: field {n!r} is not numeric") from exc
            if not np.all(np.isfinite(arr)):
                raise InputError(f"{path}: field {n!r} has NaN or infinite values")
            return arr
    if required:
        raise InputError(f"{path}: missing field {names!r}")
    return None


def _resolve_model(body_model, model_name: str, gender: str, **model_kw):
    if body_model is not None:
        return body_model

    if model_name in ("smpl", "smplh", "smplx"):
        model_kw.setdefault("gender", gender)
    return get_body_model(model_name, **model_kw)


def _pose_for(model, flat: np.ndarray, path, field: str) -> np.ndarray:
    j = len(model.joint_names)
    flat = flat.reshape(-1)
    if flat.size == 3 * j:
        return flat.reshape(j, 3)
    if flat.size < 3 * j and flat.size % 3 == 0:  # fewer joints (e.g. SMPL 72 into SMPL-H)
        out = np.zeros((j, 3))
        out[: flat.size // 3] = flat.reshape(-1, 3)
        return out
    raise InputError(f"{path}: field {field!r} has {flat.size} values; model {model.name!r} "
                     f"takes {3 * j} ({j} joints x 3)")


def _shape_for(model, betas: np.ndarray, path, field: str) -> np.ndarray:
    betas = betas.reshape(-1)
    if betas.size > model.shape_dim:
        if np.abs(betas[model.shape_dim:]).max() > 0:
            raise InputError(f"{path}: field {field!r} has {betas.size} non-zero values; model "
                             f"{model.name!r} was built with {model.shape_dim} (pass num_betas)")
        betas = betas[: model.shape_dim]
    return betas


def _rest_root(model, shape: np.ndarray) -> np.ndarray:
    # heavy: torch (~1.1 s to import)
    import torch

    with torch.no_grad():
        _, J = model.rest(torch.as_tensor(np.r_[shape, model.default_shape[shape.size:]][None],
                                          dtype=torch.float64))
    return J[0, 0].numpy().astype(np.float64)


def _rotvec_compose(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    # heavy: scipy.spatial
    from scipy.spatial.transform import Rotation

    return (Rotation.from_rotvec(a) * Rotation.from_rotvec(b)).as_rotvec()


def import_easymocap(path: str | os.PathLike, body_model=None, model: str = "smpl",
                     gender: str = "neutral", person: int = 0, **model_kw) -> BodyParams:
    """Import one person of an EasyMocap ``.json`` (``Rh``, ``Th``, ``poses``, ``shapes``).

    Parameters
    ----------
    path : the JSON file: a list of people, a dict with ``annots``, or one person's dict.
    body_model : the model to convert for (default ``get_body_model(model, ...)``).
    model, gender : model name and gender when ``body_model`` is not given.
    person : index in the list, or the EasyMocap ``id`` when one matches.

    Returns
    -------
    BodyParams with ``scale = 1`` (see module docstring for the conversion).
    """
    path = Path(path)
    data = _read_mapping(path)
    if isinstance(data, dict) and "annots" in data:
        data = data["annots"]
    if isinstance(data, list):
        if not data:
            raise InputError(f"{path}: no people in the file")
        ids = [d.get("id") for d in data if isinstance(d, dict)]
        idx = ids.index(person) if person in ids else person
        if not (0 <= idx < len(data)):
            raise InputError(f"{path}: person {person} not found ({len(data)} in the file)")
        data = data[idx]
    if not isinstance(data, dict):
        raise InputError(f"{path}: expected a person's dict with Rh, Th, poses, shapes")
    bm = _resolve_model(body_model, model, gender, **model_kw)
    poses = _field(data, "poses", path)
    shapes = _field(data, "shapes", path)
    Rh = _field(data, "Rh", path, required=False)
    Th = _field(data, "Th", path, required=False)
    Rh = np.zeros(3) if Rh is None else Rh.reshape(-1)
    Th = np.zeros(3) if Th is None else Th.reshape(-1)
    if Rh.size != 3 or Th.size != 3:
        raise InputError(f"{path}: fields 'Rh' and 'Th' must hold 3 values each")
    pose = _pose_for(bm, poses, path, "poses")
    shape = _shape_for(bm, shapes, path, "shapes")
    J0 = _rest_root(bm, shape)
    # heavy: scipy.spatial
    from scipy.spatial.transform import Rotation

    pose[0] = _rotvec_compose(Rh, pose[0])
    transl = Rotation.from_rotvec(Rh).apply(J0) + Th - J0
    return BodyParams(model=bm.name, gender=getattr(bm, "gender", gender), shape=shape,
                      pose=pose, transl=transl, scale=1.0)


def import_pamir(path: str | os.PathLike, body_model=None, model: str = "smpl",
                 gender: str = "neutral", **model_kw) -> BodyParams:
    """Import a PAMIR SMPL parameter pickle (``betas``, ``body_pose``, ``body_scale``,
    ``global_body_translation``); ``scale = body_scale``, ``transl = global_body_translation``.
    """
    path = Path(path)
    data = _read_mapping(path)
    if not isinstance(data, dict):
        raise InputError(f"{path}: expected a dict of arrays")
    bm = _resolve_model(body_model, model, gender, **model_kw)
    pose = _pose_for(bm, _field(data, ["body_pose", "pose"], path), path, "body_pose")
    shape = _shape_for(bm, _field(data, "betas", path), path, "betas")
    scale = _field(data, ["body_scale", "scale"], path, required=False)
    transl = _field(data, ["global_body_translation", "translation"], path, required=False)
    scale = 1.0 if scale is None else float(scale.reshape(-1)[0])
    transl = np.zeros(3) if transl is None else transl.reshape(-1)
    if transl.size != 3:
        raise InputError(f"{path}: field 'global_body_translation' must hold 3 values")
    return BodyParams(model=bm.name, gender=getattr(bm, "gender", gender), shape=shape,
                      pose=pose, transl=transl, scale=scale)


_SMPLX_PARTS = ("global_orient", "body_pose", "jaw_pose", "leye_pose", "reye_pose",
                "left_hand_pose", "right_hand_pose")


def import_smplify(path: str | os.PathLike, body_model=None, model: str = "smpl",
                   gender: str = "neutral", **model_kw) -> BodyParams:
    """Import smplify-x / IPNet-style parameters (``betas``, ``pose`` or ``global_orient`` +
    ``body_pose`` [+ face/hand poses], ``trans``/``transl``) from ``.pkl``, ``.npz`` or
    ``.json``; ``scale = 1``, ``transl = trans``.
    """
    path = Path(path)
    data = _read_mapping(path)
    if not isinstance(data, dict):
        raise InputError(f"{path}: expected a dict of arrays")
    bm = _resolve_model(body_model, model, gender, **model_kw)
    if "pose" in data or "poses" in data:
        flat = _field(data, ["pose", "poses"], path).reshape(-1)
    else:
        parts = []
        for name in _SMPLX_PARTS:
            arr = _field(data, name, path, required=name in ("global_orient", "body_pose"))
            if arr is None:
                break
            arr = arr.reshape(-1)
            if name.endswith("hand_pose") and arr.size != 45:
                raise InputError(f"{path}: field {name!r} has {arr.size} values; only full "
                                 "axis-angle hand poses (45) are supported, not PCA coefficients")
            parts.append(arr)
        flat = np.concatenate(parts)
    pose = _pose_for(bm, flat, path, "pose")
    shape = _shape_for(bm, _field(data, "betas", path), path, "betas")
    transl = _field(data, ["trans", "transl"], path, required=False)
    transl = np.zeros(3) if transl is None else transl.reshape(-1)
    if transl.size != 3:
        raise InputError(f"{path}: field 'trans' must hold 3 values")
    g = data.get("gender", None)
    g = g if isinstance(g, str) else getattr(bm, "gender", gender)
    return BodyParams(model=bm.name, gender=g, shape=shape, pose=pose, transl=transl, scale=1.0)


def import_npz(path: str | os.PathLike, body_model=None, **_kw) -> BodyParams:
    """Read our own ``.npz`` body parameter file (checked against ``body_model`` if given)."""
    params = BodyParams.load(path)
    if body_model is not None:
        params.check_model(body_model)
    return params


register_importer("npz", import_npz)
register_importer("easymocap", import_easymocap)
register_importer("pamir", import_pamir)
register_importer("smplify", import_smplify)
register_importer("smplify-x", import_smplify)
register_importer("ipnet", import_smplify)


def guess_format(path: str | os.PathLike) -> str:
    """Guess the importer for a file from its extension and field names."""
    path = Path(path)
    data = _read_mapping(path)
    if isinstance(data, dict) and "annots" in data or isinstance(data, list):
        return "easymocap"
    if isinstance(data, dict):
        keys = set(data)
        if {"model", "shape", "pose"} <= keys and path.suffix == ".npz":
            return "npz"
        if "Rh" in keys or "Th" in keys or "shapes" in keys:
            return "easymocap"
        if "body_scale" in keys or "global_body_translation" in keys:
            return "pamir"
        if "betas" in keys:
            return "smplify"
    raise InputError(f"{path}: cannot tell the body parameter format; pass format= one of "
                     f"{available_importers()}")


def import_body_params(path: str | os.PathLike, format: str = "auto", body_model=None,
                       **kw) -> BodyParams:
    """Import body parameters from ``path`` with the importer ``format`` (or guess it).

    Parameters
    ----------
    path : the file.
    format : ``auto``, ``npz``, ``easymocap``, ``pamir``, ``smplify`` (``smplify-x``,
        ``ipnet``) or a registered name.
    body_model : model to convert for; else built from ``model=``/``gender=`` keywords.
    """
    if format == "auto":
        format = guess_format(path)
    if format not in _IMPORTERS:
        raise InputError(f"format: unknown {format!r}; known: {available_importers()}")
    return _IMPORTERS[format](path, body_model=body_model, **kw)
