"""Registration: fit a body model to a scan (clothed or not) by optimisation in torch.

``register(scan, model, init=None, keypoints=None, preset="default", **settings) ->
BodyParams``. The ``optimization`` registrar (:class:`OptimizationRegistrar`) is configured
by a preset and validated overrides (:mod:`.config`) and runs a plan of stages
(:mod:`.plan`, run by :mod:`.runner`) with Adam on axis-angle pose, translation and shape:

0. **start** (:mod:`.init`): the multi-hypothesis search (canonical poses of
   :mod:`.hypotheses` x yaw, ranked by a symmetric distance) followed by a limb-wise search
   (:mod:`.limbs`, :mod:`.aim`) or, with keypoints (given, or detected on renders of the
   scan by :mod:`.keypoints`), the canonical pose that fits them;
1. **rigid**: root orientation and translation, fitting the torso, hips and head;
2. **pose**: all joint rotations, translation, the shape at half rate, run once with and
   once without the far-cloth rule, each followed (fits without ``init``) by the limb
   search from the settled body and by
3. **shape**: the temporary size scale handed over to the shape, then shape, pose and
   translation together; the branch with the lower shape objective goes on;
4. (fits without ``init``) the limb search from the finished body, then the **shape
   search** (:mod:`.shapes`): stature-matched phenotype starts, the lowest objective kept.

Before all this, flat support surfaces (floor, seat) are left out of the scan
(:mod:`.support`). Wherever several alternatives run, the lowest of a stated objective
goes on (:func:`.search.best_of`).

The objective (:mod:`.terms`, :mod:`.problem`): a one-sided robust data term in both
directions (clothes may sit outside the body, the body should not poke out of the scan),
pose priors with soft joint limits, a shape regulariser, optional 3D keypoints pulling the
joints. Registrars are looked up by name (:func:`get_registrar`): ``optimization`` and
``from-file`` (imports precomputed parameters); external tools add theirs with
:func:`add_registrar`.

Modules: :mod:`.scan` (inputs), :mod:`.support` (floor and seat surfaces left out of the
scan), :mod:`.terms` (cost functions and constants), :mod:`.problem` (parameters +
objective), :mod:`.stages` (the optimiser loop and the rigid, pose and shape stages),
:mod:`.search` (several starts, keep the best), :mod:`.init` and :mod:`.hypotheses`
(starting poses), :mod:`.limbs` and :mod:`.aim` (limb-wise search), :mod:`.shapes` (the
final shape search), :mod:`.keypoints` (3D keypoints from a scan, optional ``[keypoints]``
extra), :mod:`.metrics` (fit quality without ground truth), :mod:`.config` (settings and
presets), :mod:`.plan` (the stages as data), :mod:`.runner` (running a plan),
:mod:`.optimizer` (the registrar).
"""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from dressmeup.body.importers import import_body_params
from dressmeup.body.models import get_body_model
from dressmeup.body.params import BodyParams
from dressmeup.body.registration.config import PRESETS, RegistrationConfig, get_config
from dressmeup.body.registration.optimizer import OptimizationRegistrar, RegistrationResult
from dressmeup.body.registration.plan import Plan, build_plan
from dressmeup.body.registration.scan import prepare_scan
from dressmeup.body.registration.terms import JOINT_LIMITS
from dressmeup.errors import InputError


@dataclass
class FromFileRegistrar:
    """A registrar that imports precomputed parameters (another tool's fit).

    Parameters
    ----------
    path : the parameter file; format : importer name or ``auto``
        (see :func:`dressmeup.body.importers.import_body_params`).
    """

    path: str | os.PathLike | None = None
    format: str = "auto"

    def fit(self, scan, model, init: BodyParams | None = None, keypoints=None) -> RegistrationResult:
        """Return the imported parameters (the scan is not used)."""
        if self.path is None:
            raise InputError("from-file registrar: pass path= to the parameter file")
        t0 = time.perf_counter()
        params = import_body_params(Path(self.path), format=self.format, body_model=model)
        return RegistrationResult(params=params, seconds=time.perf_counter() - t0)


_REGISTRARS: dict[str, Callable[..., object]] = {
    "optimization": OptimizationRegistrar,
    "from-file": FromFileRegistrar,
}


def add_registrar(name: str, factory: Callable[..., object]) -> None:
    """Register ``factory(**options)`` returning an object with ``fit(scan, model, init,
    keypoints) -> RegistrationResult`` (or ``BodyParams``) under ``name``."""
    if not isinstance(name, str) or not name:
        raise ValueError(f"name: expected a non-empty string, got {name!r}")
    _REGISTRARS[name] = factory


def available_registrars() -> list[str]:
    """Names accepted by :func:`get_registrar`."""
    return sorted(_REGISTRARS)


def get_registrar(name: str = "optimization", **options):
    """Return the registrar ``name`` built with ``options`` (an unknown option of a
    dataclass registrar, or of ``optimization``, raises :class:`~dressmeup.errors.InputError`
    naming the known ones)."""
    if name not in _REGISTRARS:
        raise ValueError(f"registrar: unknown {name!r}; known: {available_registrars()}")
    factory = _REGISTRARS[name]
    if dataclasses.is_dataclass(factory):
        known = {f.name for f in dataclasses.fields(factory)}
        unknown = sorted(set(options) - known)
        if unknown:
            raise InputError(f"registrar {name!r}: unknown option(s) {unknown}; "
                             f"known: {sorted(known)}")
    return factory(**options)


def register(scan, model, init: BodyParams | None = None, keypoints=None,
             registrar: str = "optimization", return_result: bool = False, **options):
    """Fit a body model to a scan and return its parameters.

    Parameters
    ----------
    scan : ``(V (n,3), F (m,3))``, a trimesh, or points ``(p, 3)`` in metres.
    model : a BodyModel (e.g. ``get_body_model("anny")``) or its name.
    init : optional starting parameters (else the start search of the preset).
    keypoints : optional 3D joint positions: ``(j, 3)`` in the model's joint order with NaN
        rows for missing joints, or ``{joint_name: (3,)}``.
    registrar : registrar name (``optimization``, ``from-file``, or one added with
        :func:`add_registrar`).
    return_result : return the :class:`RegistrationResult` (timing, losses) instead.
    **options : registrar options; for ``optimization``: ``preset`` (``default``,
        ``fast``, ``naked``, ``clothed``) and settings by name (:mod:`.config`).

    Returns
    -------
    BodyParams (vertices = scale * model(shape, pose) + transl), or RegistrationResult.
    """
    if isinstance(model, str):
        model = get_body_model(model)
    result = get_registrar(registrar, **options).fit(scan, model, init=init, keypoints=keypoints)
    if isinstance(result, BodyParams):
        result = RegistrationResult(params=result, seconds=float("nan"))
    return result if return_result else result.params


__all__ = [
    "JOINT_LIMITS",
    "PRESETS",
    "FromFileRegistrar",
    "OptimizationRegistrar",
    "Plan",
    "RegistrationConfig",
    "RegistrationResult",
    "add_registrar",
    "available_registrars",
    "build_plan",
    "get_config",
    "get_registrar",
    "prepare_scan",
    "register",
]
