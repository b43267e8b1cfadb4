"""The pose library (``poses.json``): named natural poses as data, turned into axis-angle.

Angles are given about the rest body's anatomical axes (``left``, ``up``, ``forward``), so
the same library poses any body model whose rest pose has the arms out sideways, whatever
its coordinate convention.
"""

from __future__ import annotations

import json
from functools import lru_cache
from importlib import resources
from typing import Any

import numpy as np
from scipy.spatial.transform import Rotation

from dressmeup.errors import InputError

_AXES = ("left", "up", "forward")


@lru_cache(maxsize=1)
def pose_library() -> dict[str, Any]:
    """The parsed ``poses.json``."""
    return json.loads(resources.files("dressmeup.data.synth").joinpath("poses.json").read_text())


def pose_names(pose_set: str = "generator") -> list[str]:
    """Names of the library poses of ``pose_set``, in library order.

    ``"generator"`` (entries without a ``set``: what the synthetic generator draws from),
    ``"registration"`` (the hard poses of the registration benchmark),
    ``"registration-tuning"`` (bent and raised-knee poses for choosing registration
    defaults) or ``"all"``.
    """
    poses = pose_library()["poses"]
    if pose_set == "all":
        return [p["name"] for p in poses]
    return [p["name"] for p in poses if p.get("set", "generator") == pose_set]


def _mirror(entry: list) -> list:
    joint, axis, deg = entry
    other = joint.replace("left_", "right_") if joint.startswith("left_") else \
        joint.replace("right_", "left_")
    return [other, axis, deg if axis == "left" else -deg]


def pose_rotations(name: str) -> list[list]:
    """The expanded ``[joint, axis, degrees]`` list of pose ``name`` (mirrors included)."""
    for p in pose_library()["poses"]:
        if p["name"] == name:
            out = []
            for e in p.get("mirror", []):
                out += [list(e), _mirror(e)]
            return out + [list(e) for e in p.get("rotations", [])]
    raise InputError(f"pose: unknown name {name!r}; known: {pose_names('all')}")


#: limb roots aligned to the canonical rest pose before applying library angles:
#: joint -> (child joint, canonical direction as (axis, sign))
_ALIGN = {"left_shoulder": ("left_elbow", "left", 1.0), "right_shoulder": ("right_elbow", "left", -1.0),
          "left_hip": ("left_knee", "up", -1.0), "right_hip": ("right_knee", "up", -1.0)}


def pose_axis_angle(name: str, joint_names: tuple[str, ...], frame: Any,
                    rng: np.random.Generator | None = None,
                    jitter_deg: float | None = None) -> np.ndarray:
    """Axis-angle pose ``(j, 3) float64`` of library pose ``name`` for a body model.

    Parameters
    ----------
    name : library pose name.
    joint_names : the model's joint order.
    frame : object with unit vectors ``left``, ``up``, ``forward`` (rest-pose frame) and
        ``joints`` (name -> rest position). Library angles are relative to the canonical
        rest pose (arms horizontal, legs vertical); a model whose rest pose differs (e.g. an
        A-pose) first gets its upper arms and thighs rotated onto the canonical directions.
    rng : random generator for the jitter; None gives the exact library pose.
    jitter_deg : std of the per-rotation perturbation (default: the library's).
    """
    if jitter_deg is None:
        jitter_deg = float(pose_library().get("jitter", 0.0))
    rotations = []
    for joint, axis, deg in pose_rotations(name):
        if rng is not None and jitter_deg > 0:
            deg = deg + rng.normal(0.0, jitter_deg)
        rotations.append([joint, axis, deg])
    return rotations_axis_angle(rotations, joint_names, frame, what=f"pose {name!r}")


def rotations_axis_angle(rotations: list, joint_names: tuple[str, ...], frame: Any,
                         what: str = "pose",
                         max_angle_deg: dict[str, float] | None = None) -> np.ndarray:
    """Axis-angle pose ``(j, 3) float64`` of a ``[joint, axis, degrees]`` list.

    The rule of :func:`pose_axis_angle` for any rotation list: rotations of one joint compose
    in list order about the rest frame's anatomical axes, then the upper arms and thighs are
    aligned onto the canonical rest directions (see :func:`pose_axis_angle`).

    Parameters
    ----------
    rotations : ``[joint, axis, degrees]`` entries (axis in ``left``, ``up``, ``forward``).
    joint_names, frame : as for :func:`pose_axis_angle`.
    what : the pose's name in error messages.
    max_angle_deg : optional joint -> largest total rotation (degrees) of that joint's
        composed rotation, which is scaled down to it (before the alignment).
    """
    rots: dict[str, Rotation] = {}
    for joint, axis, deg in rotations:
        if joint not in joint_names:
            raise InputError(f"{what}: joint {joint!r} not in the model's joints")
        if axis not in _AXES:
            raise InputError(f"{what}: axis {axis!r} not in {_AXES}")
        r = Rotation.from_rotvec(np.deg2rad(deg) * np.asarray(getattr(frame, axis)))
        rots[joint] = r * rots[joint] if joint in rots else r
    for j, limit in (max_angle_deg or {}).items():
        if j in rots:
            v = rots[j].as_rotvec()
            ang = np.linalg.norm(v)
            if ang > np.deg2rad(limit):
                rots[j] = Rotation.from_rotvec(v * (np.deg2rad(limit) / ang))
    joints = getattr(frame, "joints", None) or {}
    for j, (child, axis, sign) in _ALIGN.items():
        if j not in joints or child not in joints or j not in joint_names:
            continue
        a = joints[child] - joints[j]
        if np.linalg.norm(a) < 1e-9:
            continue
        a = a / np.linalg.norm(a)
        target = sign * np.asarray(getattr(frame, axis))
        c = np.cross(a, target)
        ang = np.arctan2(np.linalg.norm(c), float(a @ target))
        if ang > 1e-6:
            align = Rotation.from_rotvec(c / np.linalg.norm(c) * ang)
            rots[j] = rots[j] * align if j in rots else align
    pose = np.zeros((len(joint_names), 3))
    for j, r in rots.items():
        pose[joint_names.index(j)] = r.as_rotvec()
    return pose
