"""Garment retargeting methods (the DressMeUp task): ``get_method(name, **hyperparameters)``.

Methods: ``rigid`` (root-joint alignment, the lower bound), ``skinning`` (skinning-weight
transfer, unpose, repose: the classical baseline), ``transfer`` (the body's displacement at
each vertex's closest point between the two posed bodies), ``simulate`` (generator 4's cloth
dynamics along a motion from the source body to the target: a physics reference, seconds to
minutes a pair, not a leaderboard row by default), ``isomap`` (thesis 4.3.1: Isomap
correspondences through the body template), ``isomap-refine`` (thesis 4.3.2: self-supervised
refinement network; ``isomap-refine-fast``: a narrower network; ``isomap-refine-sup``: the same
network trained with ground truth, thesis 4.3.3.1), ``isomap-offset`` (the loose-garment
variant of ``isomap``). Post-processes chain with ``+``: ``detail`` (Laplacian detail transfer,
thesis 4.3.3.2) and ``penetration`` (push penetrating vertices out), e.g.
``get_method("isomap-refine+detail+penetration")``. Hyperparameters of a post-process are
given as ``<post>__<name>`` (``detail__anchor_fraction=0.5``); the others go to the method.

Every method: ``.retarget(garment_V (n, 3), garment_F (m, 3), source: BodyParams,
target: BodyParams, body_model) -> (n, 3) float64`` with the garment's topology; the trainable
one also has ``.fit(triplets, body_model)``, ``.save(path)`` and ``.load(path)``.
"""

from __future__ import annotations

import importlib
import inspect
from typing import Any

from dressmeup.errors import InputError

__all__ = ["get_method", "available_methods", "METHODS", "POSTPROCESSES", "LEADERBOARD"]

METHODS = {
    "rigid": ("dressmeup.methods.retarget.rigid", "RigidRetarget"),
    "skinning": ("dressmeup.methods.retarget.skinning", "SkinningRetarget"),
    "transfer": ("dressmeup.methods.retarget.transfer", "BodyTransfer"),
    "simulate": ("dressmeup.methods.retarget.simulate", "SimulateRetarget"),
    "isomap": ("dressmeup.methods.retarget.isomap", "IsomapRetarget"),
    "isomap-offset": ("dressmeup.methods.retarget.isomap", "IsomapOffset"),
    "isomap-refine": ("dressmeup.methods.retarget.refine", "IsomapRefine"),
    "isomap-refine-fast": ("dressmeup.methods.retarget.refine", "IsomapRefineFast"),
    "isomap-refine-sup": ("dressmeup.methods.retarget.refine_sup", "IsomapRefineSup"),
}
POSTPROCESSES = {
    "detail": ("dressmeup.methods.retarget.postprocess", "DetailPost"),
    "penetration": ("dressmeup.methods.retarget.postprocess", "PenetrationPost"),
}


# the rows of the reference leaderboards: every base method and the chains worth comparing
LEADERBOARD = ("rigid", "skinning", "transfer", "isomap", "isomap+penetration", "isomap-offset", "isomap-refine",
               "isomap-refine+penetration", "isomap-refine-sup")


def available_methods() -> list[str]:
    """The reference baselines (leaderboard rows): base methods and the penetration chains.

    Any other ``"<method>+<post>"`` chain is accepted by :func:`get_method` too.
    """
    return list(LEADERBOARD)


def _cls(table: dict, name: str):
    mod, cls = table[name]
    return getattr(importlib.import_module(mod), cls)


def get_method(name: str, **hyperparameters: Any):
    """Build a retargeting method by name.

    Parameters
    ----------
    name : str
        ``"<method>[+<post>...]"`` with method in ``rigid``, ``skinning``, ``isomap``,
        ``isomap-offset``, ``isomap-refine``, ``isomap-refine-fast``, ``isomap-refine-sup`` and
        post in ``detail``, ``penetration``.
    **hyperparameters
        Keyword arguments of the method; ``<post>__<key>=value`` goes to a post-process.

    Returns
    -------
    The method object (a ``Pipeline`` when post-processes are chained).

    Raises
    ------
    ValueError
        Unknown method, post-process or hyperparameter (the message lists the known ones).
    """
    if not isinstance(name, str) or not name:
        raise InputError(f"name: expected a method name, got {name!r}")
    parts = [p.strip() for p in name.split("+")]
    base, posts = parts[0], parts[1:]
    if base not in METHODS:
        raise InputError(f"unknown retargeting method {base!r}; known: {sorted(METHODS)} "
                         f"(post-processes with '+': {sorted(POSTPROCESSES)})")
    post_kw: dict[str, dict[str, Any]] = {p: {} for p in posts}
    base_kw: dict[str, Any] = {}
    for key, value in hyperparameters.items():
        if "__" in key:
            post, sub = key.split("__", 1)
            if post not in post_kw:
                raise InputError(f"hyperparameter {key!r}: {post!r} is not a post-process of {name!r}")
            post_kw[post][sub] = value
        else:
            base_kw[key] = value
    method = _make(METHODS, base, base_kw)
    if not posts:
        return method
    chain = []
    for p in posts:
        if p not in POSTPROCESSES:
            raise InputError(f"unknown post-process {p!r} in {name!r}; known: {sorted(POSTPROCESSES)}")
        chain.append(_make(POSTPROCESSES, p, post_kw[p]))
    # heavy: scipy.sparse
    from dressmeup.methods.retarget.postprocess import Pipeline

    return Pipeline(method, chain)


def _make(table: dict, name: str, kw: dict[str, Any]):
    cls = _cls(table, name)
    names = getattr(cls, "hyperparameter_names", None)
    known = list(names()) if names else [p for p in inspect.signature(cls.__init__).parameters
                                         if p != "self"]
    bad = sorted(set(kw) - set(known))
    if bad:
        raise InputError(f"{name}: unknown hyperparameter(s) {bad}; known: {known}")
    return cls(**kw)
