"""Samplers of bodies and poses: many distinct subjects and poses for an edition's test split.

Bodies
------
:func:`sample_bodies` draws anny phenotypes ``(gender, age, muscle, weight, height,
proportions)`` by a Latin hypercube over :data:`BODY_RANGES`: each parameter's range is cut
into ``n`` equal strata and every stratum holds exactly one body, so any ``n >= 2`` has
bodies on both sides of the middle of every parameter (both sexes, younger and older,
light and heavy, short and tall). Ages are adult only (anny's lowest ages are children);
a body's name reads its phenotype, e.g. ``"female-42y-heavy-short"``, with the age in
years from anny's own calibration (:data:`AGE_YEARS`).

Poses
-----
:func:`sample_poses` draws one pose of a family of :data:`POSE_FAMILIES` from its
parametric template (``pose_families.json``: per joint and anatomical axis, a range of
angles in degrees), clips every angle to the anatomical limits of the same file and turns
the angles into axis-angle with the rule of the pose library
(:func:`dressmeup.data.synth.poses.rotations_axis_angle`). With a ``check``
(:class:`SelfIntersectionCheck`), a pose whose posed skin cuts through itself more than the
rest body does is rejected and drawn again.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import lru_cache
from importlib import resources
from typing import Any

import numpy as np

from dressmeup.body.params import BodyParams
from dressmeup.data.synth.garments import BodyFrame
from dressmeup.data.synth.poses import rotations_axis_angle
from dressmeup.errors import DressmeupError, InputError

#: sampled range of each anny phenotype parameter (all in anny's [0, 1]); the age range is
#: the adult one (anny's age 0.7 is about 17 years, 0.95 about 96 by :data:`AGE_YEARS`)
BODY_RANGES: dict[str, tuple[float, float]] = {
    "gender": (0.0, 1.0), "age": (0.70, 0.95), "muscle": (0.0, 1.0), "weight": (0.0, 1.0),
    "height": (0.0, 1.0), "proportions": (0.0, 1.0)}
#: anny's calibration of its age parameter to years (anny ``data/shape_calibration``,
#: "morphological age"): ``(anny age anchors, years)``, linear in between
AGE_YEARS: tuple[tuple[float, ...], tuple[float, ...]] = (
    (0.0, 0.05, 0.215, 0.415, 0.67, 0.77, 0.83, 1.0), (0.0, 1.0, 4.0, 11.0, 16.0, 18.0, 64.0, 110.0))
#: middle of each named split: gender >= 0.5 is female (anny: 0 male, 1 female); age
#: >= 0.85 (about 69 years) is old
_SPLITS = {"gender": 0.5, "age": 0.85, "weight": 0.5, "height": 0.5}


@dataclass(frozen=True)
class BodySpec:
    """One sampled body: a readable ``name``, its anny phenotype ``shape (6,) float64``
    (:data:`BODY_RANGES` order) and its age in ``years``."""

    name: str
    shape: np.ndarray = field(repr=False)
    years: float

    @property
    def female(self) -> bool:
        return bool(self.shape[0] >= _SPLITS["gender"])


def age_years(age: float) -> float:
    """Age in years of anny's age parameter (:data:`AGE_YEARS`)."""
    return float(np.interp(age, AGE_YEARS[0], AGE_YEARS[1]))


def body_name(shape: np.ndarray) -> str:
    """Readable name of an anny phenotype ``(6,)``: sex, age in years, light/heavy,
    short/tall (halves of :data:`BODY_RANGES`)."""
    g, a, _m, w, h, _p = (float(x) for x in shape)
    return "-".join(["female" if g >= _SPLITS["gender"] else "male", f"{age_years(a):.0f}y",
                     "heavy" if w >= _SPLITS["weight"] else "light",
                     "tall" if h >= _SPLITS["height"] else "short"])


def sample_bodies(rng: np.random.Generator, n: int) -> list[BodySpec]:
    """``n`` anny bodies by a Latin hypercube over :data:`BODY_RANGES`.

    Parameters
    ----------
    rng : the random generator (the draw is a function of its state).
    n : number of bodies, >= 1.

    Returns
    -------
    list of :class:`BodySpec`, names unique (a repeated name gets ``-2``, ``-3``...).

    Raises
    ------
    InputError : ``n < 1``.
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise InputError(f"sample_bodies: n must be an integer >= 1, got {n!r}")
    n = int(n)
    lo = np.array([r[0] for r in BODY_RANGES.values()])
    hi = np.array([r[1] for r in BODY_RANGES.values()])
    u = np.stack([(rng.permutation(n) + rng.random(n)) / n for _ in BODY_RANGES], axis=1)
    shapes = lo + u * (hi - lo)
    out, seen = [], {}
    for s in shapes:
        name = body_name(s)
        seen[name] = seen.get(name, 0) + 1
        if seen[name] > 1:
            name = f"{name}-{seen[name]}"
        out.append(BodySpec(name, s.copy(), age_years(s[1])))
    return out


# ---------------------------------------------------------------------------- poses
_AXES = ("left", "up", "forward")


@lru_cache(maxsize=1)
def pose_families() -> dict[str, Any]:
    """The parsed ``pose_families.json``."""
    text = resources.files("dressmeup.data.synth").joinpath("pose_families.json").read_text()
    return json.loads(text)


#: the pose families, in the file's order
POSE_FAMILIES: tuple[str, ...] = tuple(pose_families()["families"])


def _other_side(joint: str) -> str:
    if joint.startswith("left_"):
        return "right_" + joint[5:]
    if joint.startswith("right_"):
        return "left_" + joint[6:]
    return joint


def _mirror_range(axis: str, lo: float, hi: float) -> tuple[float, float]:
    return (lo, hi) if axis == "left" else (-hi, -lo)


@lru_cache(maxsize=1)
def pose_limits() -> dict[tuple[str, str], tuple[float, float]]:
    """Anatomical limits ``(joint, axis) -> (min, max)`` degrees of both sides."""
    out = {}
    for joint, axes in pose_families()["limits"].items():
        for axis, (lo, hi) in axes.items():
            out[(joint, axis)] = (float(lo), float(hi))
            if _other_side(joint) != joint:
                out[(_other_side(joint), axis)] = _mirror_range(axis, lo, hi)
    return out


def family_rotations(rng: np.random.Generator, family: str) -> list[list]:
    """One draw of family ``family``: its ``[joint, axis, degrees]`` list, every angle
    clipped to :func:`pose_limits` (a joint or axis without a limit raises)."""
    fams = pose_families()["families"]
    if family not in fams:
        raise InputError(f"sample_poses: unknown family {family!r}; known: {list(fams)}")
    spec = fams[family]
    params = {k: float(rng.uniform(lo, hi)) for k, (lo, hi) in spec.get("params", {}).items()}

    def draw(rng_spec, joint, axis, mirrored):
        if isinstance(rng_spec, str):
            v = -params[rng_spec[1:]] if rng_spec.startswith("-") else params[rng_spec]
            return -v if mirrored and axis != "left" else v
        lo, hi = _mirror_range(axis, *rng_spec) if mirrored else rng_spec
        return float(rng.uniform(lo, hi))

    rotations = []
    for joint, axis, r in spec.get("each_side", []):
        rotations.append([joint, axis, draw(r, joint, axis, False)])
        rotations.append([_other_side(joint), axis, draw(r, joint, axis, True)])
    for joint, axis, r in spec.get("rotations", []):
        rotations.append([joint, axis, draw(r, joint, axis, False)])
    if spec.get("swap_sides") and rng.random() < 0.5:
        rotations = [[_other_side(j), a, d if a == "left" else -d] for j, a, d in rotations]
    limits = pose_limits()
    for e in rotations:
        if (e[0], e[1]) not in limits:
            raise DressmeupError(f"pose family {family!r}: no anatomical limit for "
                                 f"{e[0]} about {e[1]} in pose_families.json")
        lo, hi = limits[(e[0], e[1])]
        e[2] = float(np.clip(e[2], lo, hi))
    return rotations


def sample_poses(rng: np.random.Generator, family: str, joint_names: tuple[str, ...],
                 frame: Any, *, check: Callable[[np.ndarray], bool] | None = None,
                 max_attempts: int = 50) -> np.ndarray:
    """One pose of family ``family``, within the anatomical limits (and accepted by ``check``).

    Parameters
    ----------
    rng : the random generator (the pose is a function of its state).
    family : one of :data:`POSE_FAMILIES`.
    joint_names : the body model's joint order.
    frame : the rest body's anatomical frame
        (:class:`dressmeup.data.synth.garments.BodyFrame`), as for the pose library.
    check : optional ``pose -> bool``; a rejected pose is drawn again (e.g.
        :class:`SelfIntersectionCheck`).
    max_attempts : draws before giving up.

    Returns
    -------
    (j, 3) float64 axis-angle pose.

    Raises
    ------
    InputError : unknown family.
    DressmeupError : no draw of ``max_attempts`` passed ``check``.
    """
    limits = {j: float(a) for j, a in pose_families()["max_angle"].items()}
    for _ in range(max(1, int(max_attempts))):
        pose = rotations_axis_angle(family_rotations(rng, family), tuple(joint_names), frame,
                                    what=f"pose family {family!r}", max_angle_deg=limits)
        if check is None or check(pose):
            return pose
    raise DressmeupError(f"sample_poses: no pose of family {family!r} passed the check in "
                         f"{max_attempts} draws; raise max_attempts or the check's tolerance, "
                         "or narrow the family's ranges in pose_families.json")


# --------------------------------------------------------------- self-intersection
def _hops(parents: np.ndarray) -> np.ndarray:
    """(j, j) number of bones between two joints of the kinematic tree."""
    j = len(parents)
    D = np.full((j, j), j, dtype=np.int64)
    np.fill_diagonal(D, 0)
    for a in range(j):
        p = int(parents[a])
        if p >= 0:
            D[a, p] = D[p, a] = 1
    for k in range(j):  # Floyd-Warshall on a 22-joint tree
        D = np.minimum(D, D[:, k:k + 1] + D[k:k + 1, :])
    return D


def _segments_cross(P0: np.ndarray, P1: np.ndarray, T: np.ndarray) -> np.ndarray:
    """(k,) bool: segment ``P0 -> P1`` (k, 3) crosses triangle ``T`` (k, 3, 3)
    (Moller-Trumbore, both ends included)."""
    d = P1 - P0
    e1, e2 = T[:, 1] - T[:, 0], T[:, 2] - T[:, 0]
    p = np.cross(d, e2)
    det = np.einsum("ij,ij->i", e1, p)
    ok = np.abs(det) > 1e-18
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    s = P0 - T[:, 0]
    u = np.einsum("ij,ij->i", s, p) * inv
    q = np.cross(s, e1)
    v = np.einsum("ij,ij->i", d, q) * inv
    t = np.einsum("ij,ij->i", e2, q) * inv
    return ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t >= 0) & (t <= 1)


#: torso joints and limb roots: a torso face crossing an upper arm or thigh face is soft
#: tissue pressed together (a heavy body's arm at its side, belly on the thighs), not counted
TORSO_JOINTS = ("pelvis", "spine1", "spine2", "spine3")
LIMB_ROOTS = ("left_hip", "right_hip", "left_shoulder", "right_shoulder")


def distant_parts(joint_names: tuple[str, ...], parents: np.ndarray, min_hops: int = 3
                  ) -> np.ndarray:
    """(j, j) bool: faces following these two joints are distant body parts.

    Joints at least ``min_hops`` bones apart (3: a forearm and the chest, a hand and a
    thigh, a shin and the other shin; not a thigh and its shin, nor the two thighs, whose
    creases and contact linear blend skinning pinches), except a torso joint with an upper
    arm or thigh (:data:`TORSO_JOINTS`, :data:`LIMB_ROOTS`).
    """
    far = _hops(np.asarray(parents)) >= min_hops
    names = list(joint_names)
    torso = [names.index(n) for n in TORSO_JOINTS if n in names]
    roots = [names.index(n) for n in LIMB_ROOTS if n in names]
    for t in torso:
        for r in roots:
            far[t, r] = far[r, t] = False
    return far


def self_intersections(V: np.ndarray, F: np.ndarray, face_joint: np.ndarray,
                       far: np.ndarray) -> tuple[int, int]:
    """Self-intersecting faces of a body mesh, all and between distant body parts.

    Parameters
    ----------
    V : (n, 3) float64 vertices; F : (m, 3) int64 faces.
    face_joint : (m,) int64 joint each face follows most (skinning-weight argmax).
    far : (j, j) bool which joints' faces are distant parts (:func:`distant_parts`).

    Returns
    -------
    (faces that cut the mesh (pymeshlab), faces that cut a distant part's face).
    """
    # heavy: pymeshlab (~0.3 s to import)
    import pymeshlab

    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(np.asarray(V, np.float64), np.asarray(F, np.int32)))
    ms.compute_selection_by_self_intersections_per_face()
    sel = np.flatnonzero(ms.current_mesh().face_selection_array())
    if sel.size < 2:
        return int(sel.size), 0
    tri = V[F[sel]]
    lo, hi = tri.min(1), tri.max(1)
    a_idx, b_idx = [], []
    for start in range(0, sel.size, 512):  # AABB-overlapping, distant pairs among them
        blk = slice(start, start + 512)
        ov = ((lo[blk, None] <= hi[None]) & (hi[blk, None] >= lo[None])).all(-1)
        far_ = far[face_joint[sel[blk]][:, None], face_joint[sel][None]]
        a, b = np.nonzero(ov & far_)
        a = a + start
        keep = a < b
        a_idx.append(a[keep])
        b_idx.append(b[keep])
    a, b = np.concatenate(a_idx), np.concatenate(b_idx)
    if a.size == 0:
        return int(sel.size), 0
    Fa, Fb = F[sel[a]], F[sel[b]]
    shared = (Fa[:, :, None] == Fb[:, None, :]).any((1, 2))
    a, b = a[~shared], b[~shared]
    A, B = tri[a], tri[b]
    hit = np.zeros(a.size, dtype=bool)
    for i in range(3):
        hit |= _segments_cross(A[:, i], A[:, (i + 1) % 3], B)
        hit |= _segments_cross(B[:, i], B[:, (i + 1) % 3], A)
    return int(sel.size), int(np.unique(np.concatenate([a[hit], b[hit]])).size)


class SelfIntersectionCheck:
    """Accepts a pose whose posed skin cuts through itself no more than the rest body does.

    The skin's self-intersecting faces are found by pymeshlab; those that cut a face of a
    distant body part (:func:`self_intersections`: joints three bones or more apart, e.g. a
    forearm through the chest) count. A pose is accepted when its count is at most the rest
    body's plus ``tolerance`` faces. Crossings of neighbouring parts (the skin pinched at a
    bent knee, elbow or hip, the thighs of a heavy body) are left to the skinning and not
    counted, nor a torso face crossing an upper arm or thigh face (soft tissue pressed
    together).

    Parameters
    ----------
    model : a body model (``posed``, ``skin``, ``skinning_weights``, ``joint_parents``).
    shape : (s,) float64 the body's shape parameters.
    tolerance : extra distant-part faces accepted over the rest body's.

    Attributes
    ----------
    rest_faces : the rest body's distant-part count; ``calls`` / ``accepted``: poses seen and
    accepted; ``last_faces``: the last pose's count.
    """

    def __init__(self, model, shape: np.ndarray, tolerance: int = 10) -> None:
        self.model = model
        self.shape = np.asarray(shape, dtype=np.float64)
        self.tolerance = int(tolerance)
        self.keep, self.faces = model.skin()
        W = np.asarray(model.skinning_weights)[self.keep]
        self.face_joint = W[self.faces].mean(1).argmax(1)
        self.far = distant_parts(tuple(model.joint_names), np.asarray(model.joint_parents))
        self.calls = self.accepted = 0
        self.last_faces = 0
        rest = self.vertices(np.zeros((len(model.joint_names), 3)))
        self.rest_faces = self.count(rest)

    def vertices(self, pose: np.ndarray) -> np.ndarray:
        """(s, 3) float64 posed skin vertices."""
        out = self.model.posed(BodyParams(model=self.model.name, shape=self.shape,
                                          pose=np.asarray(pose, dtype=np.float64)))
        return np.asarray(out.vertices, dtype=np.float64).reshape(-1, 3)[self.keep]

    def count(self, V: np.ndarray) -> int:
        """Distant-part self-intersecting faces of skin vertices ``V (s, 3)``."""
        return self_intersections(V, self.faces, self.face_joint, self.far)[1]

    def __call__(self, pose: np.ndarray) -> bool:
        self.calls += 1
        self.last_faces = self.count(self.vertices(pose))
        ok = self.last_faces <= self.rest_faces + self.tolerance
        self.accepted += int(ok)
        return ok


@dataclass
class PoseDraw:
    """Poses of one family drawn on several bodies: ``poses`` (one (j, 3) float64 per body),
    ``draws`` (poses drawn, rejected ones included) and ``seconds``."""

    family: str
    poses: list[np.ndarray]
    draws: int
    seconds: float

    @property
    def acceptance(self) -> float:
        """Accepted share of the drawn poses."""
        return len(self.poses) / max(1, self.draws)


def sample_family_on_bodies(model, bodies: list[BodySpec], family: str,
                            rng: np.random.Generator, tolerance: int = 10,
                            max_attempts: int = 50) -> PoseDraw:
    """One pose of ``family`` per body, each checked on that body
    (:class:`SelfIntersectionCheck`), in body order.

    Parameters
    ----------
    model : the body model the bodies' shapes belong to (e.g. ``get_body_model("anny")``).
    bodies : the bodies (:func:`sample_bodies`).
    family, rng, tolerance, max_attempts : as for :func:`sample_poses` and the check.
    """
    names = tuple(model.joint_names)
    poses, draws = [], 0
    t0 = time.perf_counter()
    for body in bodies:
        check = SelfIntersectionCheck(model, body.shape, tolerance=tolerance)
        rest = model.posed(BodyParams(model=model.name, shape=body.shape,
                                      pose=np.zeros((len(names), 3))))
        frame = BodyFrame.from_joints(rest.rest_joints, names)
        poses.append(sample_poses(rng, family, names, frame, check=check,
                                  max_attempts=max_attempts))
        draws += check.calls
    return PoseDraw(family, poses, draws, time.perf_counter() - t0)
