"""The plan of a generator-4 dataset: which bodies, poses and garments each split has, and
which (body, pose) targets each garment is dressed onto.

Every split draws its own, from its own random streams:

- **bodies**: ``design.bodies[split]`` anny phenotypes by a Latin hypercube
  (:func:`dressmeup.data.synth.sampling.sample_bodies`), so the test bodies are none of the
  train or val bodies;
- **poses**: ``design.poses_per_family[split]`` poses of every pose family
  (:data:`dressmeup.data.synth.sampling.POSE_FAMILIES`), drawn within the joint limits on
  the reference body's frame; a (body, pose) target is used only when the posed body does
  not cut through itself (:class:`~dressmeup.data.synth.sampling.SelfIntersectionCheck`);
- **garments**: ``design.garments[split]`` per category, types in turn, parameters drawn
  from the type table with the looseness (``offset``) drawn from a fit level
  (:data:`FIT_OFFSETS`, levels in turn: tight, regular, loose, shifted by one after each
  round of types so that every type comes in every fit), each designed on one of the
  split's bodies;
- **targets**: per garment, a *source* (its design body in a drawn pose) and
  ``design.targets[track]`` targets per track: ``re-pose`` (the design body in another
  pose), ``re-shape`` (another body in the source's pose) and ``cross`` (another body in
  another pose). Other bodies are only those the garment fits (:func:`fits`).

Streams: train and val draw from ``(seed, split index, stream)``; the test split draws from
seeds derived from the edition's secret (:func:`dressmeup.data.synth.secret.derive_seed`),
so without the secret nothing of it can be regenerated, and train and val are the same
with or without it. Ids are numbered over the splits in the order train, val, test
(subjects ``S001``, garments ``G001``, poses ``P001``), each split's block starting after
the previous split's *planned* size, so they do not depend on which splits are built.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from dressmeup.data.synth.common import CATEGORY_TYPES
from dressmeup.data.synth.garments import BodyFrame, garment_types, sample_params
from dressmeup.data.synth.sampling import POSE_FAMILIES, sample_bodies, sample_poses
from dressmeup.data.synth.secret import derive_seed
from dressmeup.errors import InputError
from dressmeup.hyperparameters import resolve_config

SPLITS = ("train", "val", "test")
TRACKS = ("re-pose", "re-shape", "cross")
#: fit level -> range of the garment's looseness ``offset`` (m, its distance from the design
#: body at rest); levels are taken in turn per category
FIT_OFFSETS: dict[str, tuple[float, float]] = {
    "tight": (0.004, 0.009),
    "regular": (0.009, 0.018),
    "loose": (0.018, 0.030),
}
#: body parts whose size decides whether a garment of a category fits a body
CATEGORY_REGIONS: dict[str, tuple[str, ...]] = {
    "topwear": ("chest", "waist"),
    "bottomwear": ("waist", "hips"),
    "dress": ("chest", "waist", "hips"),
}
#: skin vertices of each region: those whose dominant joint is one of these
REGION_JOINTS: dict[str, tuple[str, ...]] = {
    "chest": ("spine2", "spine3"),
    "waist": ("spine1",),
    "hips": ("pelvis", "left_hip", "right_hip"),
}
#: a garment fits a body whose region radii exceed the design body's by at most this share
#: of the garment's offset less :data:`FIT_CLEARANCE` (the garment keeps at least half its
#: looseness plus the clearance: more than the contact model's activation distance) ...
FIT_SHARE = 0.5
FIT_CLEARANCE = 0.002
#: ... and fall short of them by at most this much (m): a garment this much too large is
#: not worn
FIT_SLACK = 0.04
#: draws of a (body, pose) target before the plan gives up
MAX_DRAWS = 200


@dataclass(frozen=True)
class PlanDesign:
    """How large each split of a generator-4 dataset is.

    Attributes
    ----------
    bodies : (train, val, test) bodies.
    poses_per_family : (train, val, test) poses of each pose family.
    garments : (train, val, test) garments of each category.
    targets : track (``re-pose``, ``re-shape``, ``cross``) -> (train, val, test) targets
        per garment.
    categories : the categories made (default all).
    families : the pose families used (default all).
    fits : the fit levels of :data:`FIT_OFFSETS` taken in turn (default all; an edition of
        coarse garments leaves out ``tight``, whose looseness is below the edge's sagitta).
    """

    bodies: tuple[int, int, int] = (24, 8, 24)
    poses_per_family: tuple[int, int, int] = (3, 1, 3)
    garments: tuple[int, int, int] = (16, 4, 8)
    targets: dict[str, tuple[int, int, int]] = field(default_factory=lambda: {
        "re-pose": (2, 2, 4), "re-shape": (2, 2, 4), "cross": (3, 3, 10)})
    categories: tuple[str, ...] = tuple(CATEGORY_TYPES)
    families: tuple[str, ...] = POSE_FAMILIES
    fits: tuple[str, ...] = tuple(FIT_OFFSETS)

    def __post_init__(self) -> None:
        for name in ("bodies", "poses_per_family", "garments"):
            v = getattr(self, name)
            if (len(v) != 3 or any(isinstance(x, bool) or not isinstance(x, (int, np.integer))
                                   or x < 0 for x in v)):
                raise InputError(f"plan.{name}: expected (train, val, test) counts >= 0, "
                                 f"got {v!r}")
            object.__setattr__(self, name, tuple(int(x) for x in v))
        bad = sorted(set(self.targets) - set(TRACKS))
        if bad or any(len(v) != 3 or any(isinstance(n, bool) or not isinstance(n, int) or n < 0
                                         for n in v) for v in self.targets.values()):
            raise InputError(f"plan.targets: per track of {TRACKS} (train, val, test) counts "
                             f">= 0, got {self.targets!r}")
        object.__setattr__(self, "targets", {t: tuple(v) for t, v in self.targets.items()})
        for name, known in (("categories", CATEGORY_TYPES), ("families", POSE_FAMILIES),
                            ("fits", FIT_OFFSETS)):
            bad = sorted(set(getattr(self, name)) - set(known))
            if bad or not getattr(self, name):
                raise InputError(f"plan.{name}: a non-empty subset of {sorted(known)}, got "
                                 f"{list(getattr(self, name))!r}")
            object.__setattr__(self, name, tuple(getattr(self, name)))

    def to_dict(self) -> dict[str, Any]:
        """The design as a JSON-able dict."""
        d = asdict(self)
        d["targets"] = {t: list(v) for t, v in self.targets.items()}
        return {k: list(v) if isinstance(v, tuple) else v for k, v in d.items()}

    def n_targets(self, split: str, track: str) -> int:
        """Targets per garment of ``track`` in ``split``."""
        return self.targets.get(track, (0, 0, 0))[SPLITS.index(split)]

    @classmethod
    def from_dict(cls, d: dict[str, Any] | None) -> PlanDesign:
        """The defaults with the entries of ``d``; an unknown entry raises ``InputError``
        (:func:`dressmeup.hyperparameters.resolve_config`)."""
        return resolve_config({"default": cls()}, "default", dict(d or {}), "plan")


@dataclass(frozen=True)
class Target:
    """One sample to simulate: garment ``gid`` on subject ``sid`` in pose ``pid``; ``track``
    is ``source`` for the garment's source sample."""

    sid: str
    pid: str
    track: str

    @property
    def sample_id(self) -> str:
        """The sample id without the garment (``sid-gid-pid`` needs the garment id)."""
        return f"{self.sid}-{self.pid}"


def region_radii(rest_V: np.ndarray, labels: np.ndarray, frame: BodyFrame) -> dict[str, float]:
    """Size of every region of :data:`REGION_JOINTS` on a rest body: the RMS distance (m) of
    its skin vertices from the vertical line through their centroid.

    Parameters
    ----------
    rest_V : (b, 3) float64 skin vertices at rest.
    labels : (b,) dominant joint name of each vertex.
    frame : the body's frame (``up``).
    """
    out = {}
    for region, joints in REGION_JOINTS.items():
        P = rest_V[np.isin(labels, joints)]
        d = P - P.mean(0)
        d -= np.outer(d @ frame.up, frame.up)
        out[region] = float(np.sqrt(np.mean(np.einsum("ij,ij->i", d, d))))
    return out


def fits(category: str, offset: float, design: dict[str, float], body: dict[str, float]
         ) -> bool:
    """Whether a garment of ``category`` and looseness ``offset`` (m), designed on a body of
    region radii ``design``, fits a body of region radii ``body``: in every region of the
    category the body is at most ``FIT_SHARE * offset - FIT_CLEARANCE`` larger and at most
    ``FIT_SLACK`` smaller."""
    for region in CATEGORY_REGIONS[category]:
        grow = body[region] - design[region]
        if grow > FIT_SHARE * offset - FIT_CLEARANCE or grow < -FIT_SLACK:
            return False
    return True


def split_streams(split: str, seed: int, secret: bytes | None) -> dict[str, np.random.Generator]:
    """The random streams of one split: ``bodies``, ``poses``, ``garments``, ``targets``,
    ``textures`` (module docstring)."""
    names = ("bodies", "poses", "garments", "targets", "textures")
    if split == "test":
        if secret is None:
            raise InputError("the test split of generator 4 is seeded by the edition's secret: "
                             "give it (dressmeup synth --edition E --secret FILE), or build "
                             "train and val only")
        return {n: np.random.default_rng(derive_seed(secret, "test", n)) for n in names}
    k = SPLITS.index(split)
    return {n: np.random.default_rng([int(seed), k, i]) for i, n in enumerate(names)}


def id_offsets(design: PlanDesign) -> dict[str, dict[str, int]]:
    """Per split, the first number of its subjects, garments and poses (module docstring)."""
    out, s, g, p = {}, 1, 1, 1
    for k, split in enumerate(SPLITS):
        out[split] = {"subjects": s, "garments": g, "poses": p}
        s += design.bodies[k]
        g += design.garments[k] * len(design.categories)
        p += design.poses_per_family[k] * len(design.families)
    return out


def plan_split(split: str, design: PlanDesign, kit: Any, seed: int, secret: bytes | None,
               pose_ok: Any) -> dict[str, Any]:
    """The plan of one split.

    Parameters
    ----------
    split : ``train``, ``val`` or ``test``.
    design : the sizes.
    kit : the body kit (:class:`dressmeup.data.synth.generator4.BodyKit`).
    seed : the public seed (train, val); secret : the test split's secret.
    pose_ok : ``(shape (s,), pose (j, 3)) -> bool``, whether a body may take a pose.

    Returns
    -------
    dict with ``subjects`` (id -> ``shape``, ``name``, ``split``), ``poses`` (id ->
    ``family``, ``pose`` (j, 3) list, ``split``), ``garments`` (id -> ``type``,
    ``category``, ``fit``, ``params``, ``split``, ``design_subject``, ``targets``: list of
    :class:`Target`).
    """
    k = SPLITS.index(split)
    rng = split_streams(split, seed, secret)
    first = id_offsets(design)[split]
    subjects, radii, garments = _bodies_and_garments(split, design, kit, rng, first)
    frame0 = kit.rest(np.asarray(kit.model.default_params().shape))[1]
    poses = {}
    for family in design.families:
        for _ in range(design.poses_per_family[k]):
            pid = f"P{first['poses'] + len(poses):03d}"
            q = sample_poses(rng["poses"], family, kit.joint_names, frame0)
            poses[pid] = {"family": family, "pose": np.round(q, 9).tolist(), "split": split}
    for gid, g in garments.items():
        g["targets"] = _draw_targets(g, design, rng["targets"], subjects, poses, radii,
                                     pose_ok, gid)
    return {"subjects": subjects, "poses": poses, "garments": garments}


def split_garments(split: str, design: PlanDesign, kit: Any, seed: int, secret: bytes | None
                   ) -> tuple[dict[str, Any], dict[str, Any]]:
    """The bodies and garments of one split as :func:`plan_split` draws them, without its
    poses and targets (the garments depend on neither): ``(subjects, garments)``, records as
    in :func:`plan_split` (garments without ``targets``). Cheap enough to check a training
    set's garments against another edition's test garments."""
    rng = split_streams(split, seed, secret)
    subjects, _, garments = _bodies_and_garments(split, design, kit, rng,
                                                 id_offsets(design)[split])
    return subjects, garments


def _bodies_and_garments(split: str, design: PlanDesign, kit: Any,
                         rng: dict[str, np.random.Generator], first: dict[str, int]
                         ) -> tuple[dict[str, Any], dict[str, dict[str, float]], dict[str, Any]]:
    """``(subjects, their region radii, garments)`` of one split from its streams."""
    k = SPLITS.index(split)
    subjects: dict[str, Any] = {}
    radii: dict[str, dict[str, float]] = {}
    for i, b in enumerate(sample_bodies(rng["bodies"], design.bodies[k])
                          if design.bodies[k] else []):
        sid = f"S{first['subjects'] + i:03d}"
        subjects[sid] = {"shape": np.round(b.shape, 6).tolist(), "name": b.name, "split": split}
        rest_V, frame = kit.rest(np.asarray(subjects[sid]["shape"]))
        radii[sid] = region_radii(rest_V, kit.labels, frame)
    garments = _plan_garments(split, design, rng["garments"], first["garments"], subjects,
                              radii)
    return subjects, radii, garments


def _plan_garments(split: str, design: PlanDesign, rng: np.random.Generator, first: int,
                   subjects: dict[str, Any], radii: dict[str, dict[str, float]]
                   ) -> dict[str, Any]:
    """Types, fits, parameters and design subjects of one split's garments."""
    k = SPLITS.index(split)
    garments: dict[str, Any] = {}
    sids = sorted(subjects)
    fits_order = design.fits
    n = design.garments[k]
    for category in design.categories:
        types = CATEGORY_TYPES[category]
        for i in range(n):
            gid = f"G{first + len(garments):03d}"
            gtype = types[i % len(types)]
            # the fit advances once more after each round of types, so that types and fits
            # cross (three types and three fits in plain turns would make every t-shirt tight)
            fit = fits_order[(i + i // len(types)) % len(fits_order)]
            params = sample_params(gtype, rng)
            lo, hi = FIT_OFFSETS[fit]
            params["offset"] = float(rng.uniform(lo, hi))
            params = {p: (round(v, 6) if isinstance(v, float) else v) for p, v in params.items()}
            if not sids:
                raise InputError(f"plan: split {split} has garments but no bodies")
            need = (design.n_targets(split, "re-shape")
                    + min(1, design.n_targets(split, "cross")))
            able = [s for s in sids
                    if sum(fits(category, params["offset"], radii[s], radii[o])
                           for o in sids if o != s) >= need]
            if not able:
                raise InputError(f"plan: no body of split {split} has {need} other bodies a "
                                 f"{fit} {gtype} designed on it fits; draw more bodies")
            garments[gid] = {"type": gtype, "category": garment_types()[gtype]["category"],
                             "fit": fit, "params": params, "split": split,
                             "design_subject": able[int(rng.integers(len(able)))]}
    return garments


def _draw_targets(g: dict[str, Any], design: PlanDesign, rng: np.random.Generator,
                  subjects: dict[str, Any], poses: dict[str, Any],
                  radii: dict[str, dict[str, float]], pose_ok: Any, gid: str) -> list[Target]:
    """The source and the targets of one garment (module docstring), drawn in the order
    source, re-pose, re-shape, cross."""
    home = g["design_subject"]
    others = [s for s in sorted(subjects) if s != home
              and fits(g["category"], g["params"]["offset"], radii[home], radii[s])]
    pids = sorted(poses)

    def ok(sid: str, pid: str) -> bool:
        return pose_ok(np.asarray(subjects[sid]["shape"]), np.asarray(poses[pid]["pose"]))

    def draw(pick_sid, pick_pid, taken: set[tuple[str, str]], track: str) -> Target:
        for _ in range(MAX_DRAWS):
            sid, pid = pick_sid(), pick_pid()
            if (sid, pid) not in taken and ok(sid, pid):
                taken.add((sid, pid))
                return Target(sid, pid, track)
        raise InputError(f"plan: garment {gid} found no {track} target in {MAX_DRAWS} draws "
                         "(too few bodies or poses it fits); draw more")

    taken: set[tuple[str, str]] = set()
    source = draw(lambda: home, lambda: pids[int(rng.integers(len(pids)))], taken, "source")
    out = [source]
    rest = [p for p in pids if p != source.pid]
    if not rest and (design.n_targets(g["split"], "re-pose")
                     or design.n_targets(g["split"], "cross")):
        raise InputError(f"plan: split {g['split']} has one pose; re-pose and cross targets "
                         "need two or more (poses_per_family, families)")
    for _ in range(design.n_targets(g["split"], "re-pose")):
        out.append(draw(lambda: home, lambda: rest[int(rng.integers(len(rest)))], taken,
                        "re-pose"))
    for _ in range(design.n_targets(g["split"], "re-shape")):
        out.append(draw(lambda: others[int(rng.integers(len(others)))], lambda: source.pid,
                        taken, "re-shape"))
    for _ in range(design.n_targets(g["split"], "cross")):
        out.append(draw(lambda: others[int(rng.integers(len(others)))],
                        lambda: rest[int(rng.integers(len(rest)))], taken, "cross"))
    return out
