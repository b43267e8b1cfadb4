"""Canonical starting poses for the multi-hypothesis initialisation.

A hypothesis is described by anatomical directions, not joint angles, so it poses any
SMPL-like model whatever its rest pose (anny's arms hang in an A-pose, SMPL's are out
sideways): the upper arms and thighs are turned from their rest direction onto a target
direction, then knees, elbows and spine get a bend. Directions are in the model frame
(y up, facing +z, the body's left on +x); right-side targets mirror the left ones.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

#: name -> directions and bends. ``arm``: left upper-arm direction (x left, y up, z
#: forward); ``thigh``: left thigh direction; ``knee``, ``elbow``, ``spine`` bends (degrees:
#: knees bend the shin back, elbows bend the forearm forward, the spine leans forward);
#: ``pelvis``: forward tilt of the whole body (degrees, the root's rotation before the
#: search's yaw), so a torso bent further than the short rigid stages can turn it is still
#: reached (15 rigid steps turn the root by at most ~13 degrees). Arm and thigh directions
#: are in the world (the tilt and the spine bend are undone for them). ``right``: overrides
#: of ``arm``, ``thigh``, ``knee``, ``elbow`` for the right side, written like the left's
#: (x towards the body's own side), for the asymmetric poses; without it the right side
#: mirrors the left.
CANONICAL_POSES: dict[str, dict] = {
    "arms-down": {"arm": (0.25, -1.0, 0.0)},
    "a-pose": {"arm": (1.0, -1.0, 0.0)},
    "t-pose": {"arm": (1.0, 0.0, 0.0)},
    "arms-up": {"arm": (0.7, 1.0, 0.0), "elbow": 10},
    "wide-stance": {"arm": (1.0, -0.3, 0.0), "thigh": (0.45, -1.0, 0.0)},
    "sitting": {"arm": (0.25, -1.0, 0.35), "thigh": (0.12, -0.05, 1.0), "knee": 90,
                "elbow": 40},
    "bending": {"arm": (0.2, -1.0, 0.5), "spine": 50},
    "arms-forward": {"arm": (0.3, -0.2, 1.0), "elbow": 60},
    "deep-bend": {"pelvis": 60, "spine": 30, "thigh": (0.05, -1.0, 0.2), "knee": 20,
                  "arm": (0.15, -1.0, 0.1)},
}
#: A stride: one thigh 55 degrees forward with the knee bent 70, the other 17 degrees back
#: with the knee bent 15, arms down (a step up, a lunge, one knee raised); once with the
#: left leg in front, once with the right.
_FRONT_LEG = {"thigh": (0.1, -0.57, 0.82), "knee": 70}
_BACK_LEG = {"thigh": (0.05, -0.95, -0.3), "knee": 15}
CANONICAL_POSES["stride-left"] = {"arm": (0.25, -1.0, 0.0), **_FRONT_LEG, "right": _BACK_LEG}
CANONICAL_POSES["stride-right"] = {"arm": (0.25, -1.0, 0.0), **_BACK_LEG, "right": _FRONT_LEG}

#: Hypotheses defined but tried only when asked for (``hypotheses=``): the strides help the
#: raised-knee tuning fits but make a clothed walking fit 13 mm worse
#: (benchmarks/results/studies/registration/2026-12-03-folded-legs.md).
OPT_IN_HYPOTHESES: tuple[str, ...] = ("stride-left", "stride-right")
#: The hypotheses tried by default: all of :data:`CANONICAL_POSES` but the opt-in ones.
DEFAULT_HYPOTHESES: tuple[str, ...] = tuple(n for n in CANONICAL_POSES
                                            if n not in OPT_IN_HYPOTHESES)


def align_directions(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Axis-angle (3,) of the shortest rotation turning direction ``a`` onto ``b``."""
    a = a / np.linalg.norm(a)
    b = b / np.linalg.norm(b)
    c = np.cross(a, b)
    s = np.linalg.norm(c)
    ang = np.arctan2(s, float(a @ b))
    if s < 1e-9:
        return np.zeros(3)
    return c / s * ang


def canonical_pose(name: str, joint_names, rest_joints: np.ndarray) -> np.ndarray:
    """Axis-angle pose ``(j, 3) float64`` of hypothesis ``name`` for a model (row 0, the
    root, holds the ``pelvis`` tilt; a search composes its yaw with it).

    Parameters
    ----------
    name : a key of :data:`CANONICAL_POSES`.
    joint_names : the model's joint names (SMPL-like names; missing joints are skipped).
    rest_joints : (j, 3) joint positions of the model's rest pose (model frame).
    """
    if name not in CANONICAL_POSES:
        raise ValueError(f"hypothesis: unknown pose {name!r}; known: {sorted(CANONICAL_POSES)}")
    spec = CANONICAL_POSES[name]
    names = list(joint_names)
    pose = np.zeros((len(names), 3))
    J = np.asarray(rest_joints, dtype=np.float64)

    def idx(n):
        return names.index(n) if n in names else None

    tilt = Rotation.identity()  # the root's forward tilt, which everything inherits
    if spec.get("pelvis"):
        pose[0] = (np.deg2rad(spec["pelvis"]), 0.0, 0.0)
        tilt = Rotation.from_rotvec(pose[0])
    trunk = tilt  # the root's and the spine's rotation, which the shoulders inherit
    if spec.get("spine"):
        parts = [n for n in ("spine1", "spine2", "spine3") if n in names]
        for n in parts:
            pose[names.index(n)] = (np.deg2rad(spec["spine"]) / len(parts), 0.0, 0.0)
            trunk = trunk * Rotation.from_rotvec(pose[names.index(n)])
    for side, sx in (("left", 1.0), ("right", -1.0)):
        limbs = {**spec, **spec.get("right", {})} if side == "right" else spec
        for root, child, key in (("shoulder", "elbow", "arm"), ("hip", "knee", "thigh")):
            r, c = idx(f"{side}_{root}"), idx(f"{side}_{child}")
            if key in limbs and r is not None and c is not None:
                target = np.asarray(limbs[key], dtype=np.float64) * (sx, 1.0, 1.0)
                # the target is in the world: undo the trunk's (arms) or the tilt's (thighs)
                target = (trunk if key == "arm" else tilt).inv().apply(target)
                pose[r] = align_directions(J[c] - J[r], target)
        k = idx(f"{side}_knee")
        if k is not None and limbs.get("knee"):
            pose[k] = (np.deg2rad(limbs["knee"]), 0.0, 0.0)
        e = idx(f"{side}_elbow")
        if e is not None and limbs.get("elbow"):
            pose[e] = (0.0, -sx * np.deg2rad(limbs["elbow"]), 0.0)
    return pose
