"""The registrar's settings: small frozen groups, named presets, validated overrides.

A fit is configured by a :class:`RegistrationConfig`, built by :func:`get_config` from a
preset (:data:`PRESETS`: ``default``, ``fast``, ``naked``, ``clothed``) and keyword
overrides named after the fields of the groups (``get_config("naked", seed=3,
iterations=(60, 200, 160))``). Every setting is documented once, in its group:

- :class:`DataTerm`: what of the scan the data term sees and what a residual costs;
- :class:`Priors`: pose, joint-limit, shape and keypoint weights;
- :class:`Schedule`: step counts and learning rates of the stages;
- :class:`StartSearch`: how a fit without ``init`` starts;
- :class:`Limbs`: the limb-wise searches;
- :class:`Shapes`: the final search over phenotype starts;
- :class:`ScanInput`: the scan's up axis and its support surfaces;
- :class:`Runtime`: seed, device, threads, progress.

The stages a configuration runs, in order, are its plan (:mod:`.plan`).
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields, replace
from numbers import Real
from typing import Any

from dressmeup.body.registration.hypotheses import CANONICAL_POSES, DEFAULT_HYPOTHESES
from dressmeup.body.registration.limbs import FIRST_KNEE_BENDS
from dressmeup.body.registration.scan import UP_ROTATIONS
from dressmeup.errors import InputError
from dressmeup.hyperparameters import resolve_config


@dataclass(frozen=True)
class DataTerm:
    """The data term (:mod:`.terms`, :meth:`.problem.FitProblem.loss`).

    Attributes
    ----------
    inside_weight : weight of residuals with the body inside the scan (clothing); 1 with a
        ``sigma_in`` equal to ``sigma_out`` makes the term symmetric (naked scans).
    sigma_out, sigma_in : Geman-McClure scales (m) of outside and inside residuals; the
        small ``sigma_in`` saturates for cloth a few cm off the skin.
    point_weight : weight of the point-to-point term (keeps pairs from sliding along limbs).
    cloth_max : inside gaps (m) beyond which a residual is not clothing.
    far_cloth : what a scan point farther than ``cloth_max`` outside the body does in the
        stages whose objective turns the rule on (the shape stage; a pose stage of the
        branches, see :mod:`.plan`): ``"free"`` pulls no more than one at ``cloth_max``
        (a skirt's far cloth does not bend the legs into it), ``"pull"`` pulls by its excess
        like an outside residual (then the pose stage runs once).
    unseen_hit_radius : in the shape stage a body point carries no body -> scan cost unless
        some scan point's nearest body point lies within this distance (m) of it on the rest
        body (a side the capture missed); None: only the facing test frees body points.
    n_scan_points, n_body_points : scan samples and body vertices the data term uses.
    """

    inside_weight: float = 0.5
    sigma_out: float = 0.15
    sigma_in: float = 0.01
    point_weight: float = 0.3
    cloth_max: float = 0.06
    far_cloth: str = "free"
    unseen_hit_radius: float | None = 0.03
    n_scan_points: int = 8000
    n_body_points: int = 5000


@dataclass(frozen=True)
class Priors:
    """Weights of the terms besides the data term.

    Attributes
    ----------
    pose_prior_weight : squared joint rotations (root excluded; per-joint scales in
        :data:`.terms.PRIOR_SCALE`).
    limit_weight : squared violations of the soft joint limits (:data:`.terms.JOINT_LIMITS`).
    shape_weight : squared distance of the shape from the model's average (shape stage).
    keypoint_weight : squared joint-to-keypoint distances, while the fit starts and, for
        keypoints passed by the caller, throughout.
    keypoint_refine_weight : the keypoint weight after the start when the keypoints were
        detected on the scan (detectors place joints a few cm off a model's joint centres).
    """

    pose_prior_weight: float = 1e-2
    limit_weight: float = 1e-2
    shape_weight: float = 1e-4
    keypoint_weight: float = 1.0
    keypoint_refine_weight: float = 0.1


@dataclass(frozen=True)
class Schedule:
    """Adam steps and learning rates of the fit's stages.

    Attributes
    ----------
    iterations : steps of the rigid (``global``), pose and shape stages.
    lr_pose, lr_transl, lr_shape : learning rates of the pose (axis-angle, rad), the
        translation (m) and the shape (model units; phenotypes through a sigmoid).
    """

    iterations: tuple[int, int, int] = (60, 160, 160)
    lr_pose: float = 0.015
    lr_transl: float = 0.01
    lr_shape: float = 0.05


@dataclass(frozen=True)
class StartSearch:
    """How a fit without ``init`` starts (:mod:`.init`, :mod:`.hypotheses`).

    Attributes
    ----------
    init_route : ``"hypotheses"`` (the multi-hypothesis search), ``"keypoints"`` (3D
        keypoints detected on renders of the scan; the ``[keypoints]`` extra) or ``"auto"``
        (with the extra both starts run and the one with the lower symmetric score goes on;
        without it the hypotheses). Keypoints passed to a fit always start it.
    hypotheses : canonical poses tried (:data:`.hypotheses.CANONICAL_POSES`); empty: the
        rest pose with a yaw search.
    hypothesis_steps : rigid steps of each yaw candidate (core joints), rigid steps of each
        (pose, yaw) hypothesis (whole body), pose steps of each refined hypothesis.
    hypothesis_keep : rigid hypotheses refined (plus the best one facing away when all of
        them face one way).
    hypothesis_yaws : yaws that go on to the pose hypotheses (plus the one opposite the best).
    yaw_candidates : yaws tried on the core joints, evenly spaced over the full turn.
    """

    init_route: str = "hypotheses"
    hypotheses: tuple[str, ...] = DEFAULT_HYPOTHESES
    hypothesis_steps: tuple[int, int, int] = (20, 15, 40)
    hypothesis_keep: int = 3
    hypothesis_yaws: int = 3
    yaw_candidates: int = 8


@dataclass(frozen=True)
class Limbs:
    """The limb-wise searches (:mod:`.limbs`): other directions for each arm and leg, kept
    when the settled body fits the scan better. They run in fits without ``init``.

    Attributes
    ----------
    limb_search : search right after the multi-hypothesis start (legs with
        ``limb_first_knee_bends``, nothing aimed).
    limb_first_knee_bends : knee bends (degrees) the first search tries for the legs; later
        searches try 0, 50, 100 and 140 (from a rough body a shin folded up into a skirt
        explains cloth and can outscore the hanging one).
    limb_search_after_pose : search again after the pose stage, from the settled body.
    limb_aim : which limbs the later searches also aim at scan the body leaves unexplained
        (``"none"``, ``"arms"``, ``"all"``).
    limb_search_final : search a last time from the finished body; a kept move runs the
        shape stage again.
    """

    limb_search: bool = True
    limb_first_knee_bends: tuple[float, ...] = FIRST_KNEE_BENDS
    limb_search_after_pose: bool = True
    limb_aim: str = "all"
    limb_search_final: bool = True


@dataclass(frozen=True)
class Shapes:
    """The final shape search (:mod:`.shapes`; phenotype models, fits without ``init``).

    Attributes
    ----------
    shape_search : restart the shape from stature-matched starts (one per gender, the
        build that fits the scan best), each with half a pose stage and the shape stage,
        and keep the body whose shape objective is lowest (the fitted one included).
    """

    shape_search: bool = True


@dataclass(frozen=True)
class ScanInput:
    """What the scan is (:mod:`.scan`, :mod:`.support`).

    Attributes
    ----------
    up : the scan's up axis (``x``, ``-x``, ``y``, ``-y``, ``z``, ``-z``); the fit turns
        the scan to y up and the result back. None means y and refuses a scan that does not
        look upright (:func:`.scan.check_upright`); ``"y"`` skips that check.
    remove_support : leave the large flat surfaces of a capture (floor, a seat's top and
        sides, a wall) out of the scan before the fit.
    support_sample : the supports are found on this many times ``n_scan_points`` samples.
    """

    up: str | None = None
    remove_support: bool = True
    support_sample: int = 4


@dataclass(frozen=True)
class Runtime:
    """How a fit runs; none of these change its result.

    Attributes
    ----------
    seed : sampling seed of the scan and body points (this one changes the result).
    device : torch device.
    num_threads : torch threads during the fit (restored afterwards; None leaves torch's
        setting); one is fastest for these small problems.
    verbose : progress bars.
    """

    seed: int = 0
    device: str = "cpu"
    num_threads: int | None = 1
    verbose: bool = True


#: The groups of a :class:`RegistrationConfig`: attribute name -> class.
GROUPS: dict[str, type] = {"data": DataTerm, "priors": Priors, "schedule": Schedule,
                           "start": StartSearch, "limbs": Limbs, "shapes": Shapes,
                           "scan": ScanInput, "runtime": Runtime}


@dataclass(frozen=True)
class RegistrationConfig:
    """All settings of the ``optimization`` registrar, in groups (see module docstring)."""

    data: DataTerm = field(default_factory=DataTerm)
    priors: Priors = field(default_factory=Priors)
    schedule: Schedule = field(default_factory=Schedule)
    start: StartSearch = field(default_factory=StartSearch)
    limbs: Limbs = field(default_factory=Limbs)
    shapes: Shapes = field(default_factory=Shapes)
    scan: ScanInput = field(default_factory=ScanInput)
    runtime: Runtime = field(default_factory=Runtime)

    def flat(self) -> dict[str, Any]:
        """Every setting by its (unique) name."""
        return {f.name: getattr(getattr(self, g), f.name)
                for g, cls in GROUPS.items() for f in fields(cls)}


#: setting name -> its group's attribute name
SETTING_GROUP: dict[str, str] = {f.name: g for g, cls in GROUPS.items() for f in fields(cls)}

#: Named configurations. ``default``: the registrar as measured in docs/body-models.md
#: (clothed or naked scans). ``naked``: a symmetric data term (a limb buried in the torso
#: costs as much as one outside it). ``clothed``: a weaker pull of the body towards the
#: scan surface. ``fast``: fewer samples and steps, for previews and tests (not measured
#: on the perf suites).
PRESETS: dict[str, RegistrationConfig] = {
    "default": RegistrationConfig(),
    "naked": RegistrationConfig(data=DataTerm(inside_weight=1.0, sigma_in=0.15)),
    "clothed": RegistrationConfig(data=DataTerm(inside_weight=0.2)),
    "fast": RegistrationConfig(
        data=DataTerm(n_scan_points=2500, n_body_points=1500),
        schedule=Schedule(iterations=(30, 120, 120)),
        start=StartSearch(hypothesis_steps=(10, 8, 20), hypothesis_keep=2, hypothesis_yaws=2,
                          yaw_candidates=4)),
}


def get_config(preset: str | RegistrationConfig = "default", **overrides: Any
               ) -> RegistrationConfig:
    """The configuration of ``preset`` (a name of :data:`PRESETS` or a configuration) with
    ``overrides``: settings by name (``seed=3``) or whole groups (``data=DataTerm(...)``).
    Each group's overrides go through the toolkit's preset rule
    (:func:`dressmeup.hyperparameters.resolve_config`: ints, floats, booleans and strings
    typed), then the ranges are checked (:func:`check_config`).

    Raises
    ------
    InputError
        Unknown preset, unknown setting, or a value out of its range.
    """
    config = resolve_config(PRESETS, preset, {}, what="registration preset")
    unknown = sorted(set(overrides) - set(SETTING_GROUP) - set(GROUPS))
    if unknown:
        raise InputError(f"registrar 'optimization': unknown option(s) {unknown}; "
                         f"known: {sorted(SETTING_GROUP)}")
    groups = {g: overrides[g] for g in GROUPS if g in overrides}
    for g, value in groups.items():
        if not isinstance(value, GROUPS[g]):
            raise InputError(f"{g}: expected a {GROUPS[g].__name__}, got {value!r}")
    config = replace(config, **groups)
    per_group: dict[str, dict[str, Any]] = {}
    for name, value in overrides.items():
        if name in SETTING_GROUP:
            per_group.setdefault(SETTING_GROUP[name], {})[name] = _normalised(name, value)
    for g, kw in per_group.items():  # typed per field by the toolkit's one preset rule
        part = getattr(config, g)
        config = replace(config, **{g: resolve_config({g: part}, part, kw, what=g)})
    check_config(config)
    return config


#: settings held as tuples (lists from JSON or the command line are turned into tuples)
_TUPLES = ("iterations", "hypothesis_steps", "hypotheses", "limb_first_knee_bends")


def _normalised(name: str, value: Any) -> Any:
    """Lists (JSON, the command line) and arrays of a tuple setting as a tuple."""
    if name in _TUPLES and not isinstance(value, (str, bytes, dict)):
        if hasattr(value, "tolist"):
            value = value.tolist()
        if isinstance(value, (list, tuple)):
            return tuple(value)
    return value


def _real(x) -> bool:
    """A number (numpy's too), not a bool or a string; NaN compares False later."""
    return isinstance(x, Real) and not isinstance(x, bool)


def _count(x) -> bool:
    return _real(x) and float(x) == int(x) and x >= 0


def check_config(config: RegistrationConfig) -> None:
    """Raise :class:`~dressmeup.errors.InputError` naming the first setting out of range."""
    s = config.flat()
    for name, allowed in (("far_cloth", ("free", "pull")),
                          ("init_route", ("hypotheses", "keypoints", "auto")),
                          ("limb_aim", ("none", "arms", "all"))):
        if s[name] not in allowed:
            raise InputError(f"{name}: expected one of {', '.join(allowed)}, got {s[name]!r}")
    for name in ("inside_weight", "sigma_out", "sigma_in", "point_weight", "cloth_max",
                 "pose_prior_weight", "limit_weight", "shape_weight", "keypoint_weight",
                 "keypoint_refine_weight", "lr_pose", "lr_transl", "lr_shape"):
        if not (_real(s[name]) and s[name] >= 0):
            raise InputError(f"{name}: expected a number >= 0, got {s[name]!r}")
    radius = s["unseen_hit_radius"]
    if radius is not None and not (_real(radius) and 0 < radius < 1):
        raise InputError(f"unseen_hit_radius: expected None or a distance in metres in "
                         f"(0, 1), got {radius!r}")
    for name in ("n_scan_points", "n_body_points", "hypothesis_keep", "hypothesis_yaws",
                 "yaw_candidates", "support_sample"):
        if not (_count(s[name]) and s[name] >= 1):
            raise InputError(f"{name}: expected a whole number >= 1, got {s[name]!r}")
    for name in ("iterations", "hypothesis_steps"):
        if not (isinstance(s[name], tuple) and len(s[name]) == 3
                and all(_count(n) for n in s[name])):
            raise InputError(f"{name}: expected three step counts >= 0 like "
                             f"{PRESETS['default'].flat()[name]}, got {s[name]!r}")
    if not isinstance(s["hypotheses"], tuple) or any(
            p not in CANONICAL_POSES for p in s["hypotheses"]):
        raise InputError(f"hypotheses: expected a list of {', '.join(CANONICAL_POSES)}; "
                         f"got {s['hypotheses']!r}")
    bends = s["limb_first_knee_bends"]
    if not (isinstance(bends, tuple) and bends and all(_real(b) and 0 <= b < 180
                                                       for b in bends)):
        raise InputError("limb_first_knee_bends: expected a non-empty list of knee bends in "
                         f"degrees, each in [0, 180) (default {list(FIRST_KNEE_BENDS)}); "
                         f"got {bends!r}")
    if s["up"] is not None and s["up"] not in UP_ROTATIONS:
        raise InputError(f"up: expected one of {', '.join(UP_ROTATIONS)}, got {s['up']!r}")
    threads = s["num_threads"]
    if threads is not None and not (_count(threads) and threads >= 1):
        raise InputError(f"num_threads: expected None or a whole number >= 1, got {threads!r}")
    if not _count(s["seed"]):
        raise InputError(f"seed: expected a whole number >= 0, got {s['seed']!r}")


def describe(config: RegistrationConfig) -> dict[str, Any]:
    """The settings that differ from the default, by name (for records and logs)."""
    default = PRESETS["default"].flat()
    return {k: v for k, v in config.flat().items() if v != default[k]}


__all__ = ["GROUPS", "PRESETS", "DataTerm", "Limbs", "Priors", "RegistrationConfig",
           "Runtime", "ScanInput", "Schedule", "Shapes", "StartSearch", "check_config",
           "describe", "get_config"]
