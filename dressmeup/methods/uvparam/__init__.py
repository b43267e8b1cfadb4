"""UV parameterisation methods: ``get_method(name, **hyperparameters).parameterize(V, F)``.

Methods (all return per-corner UVs, see :class:`UVResult`):

``xatlas``    xatlas' own segmentation, parameterisation and packing.
``lscm``      least-squares conformal maps per chart of a normal-cone segmentation (libigl).
``harmonic``  harmonic maps with the boundary on a circle, per chart (libigl).
``slim``      SLIM symmetric-Dirichlet maps per chart (libigl): the low-distortion reference.
``neural``    the thesis' self-supervised method: PatchNet (DiffusionNet) patches, per-patch
              forward/backward MLPs trained on the mesh (or loaded from a checkpoint with
              ``checkpoint=PATH`` and inferred on a new discretisation), packed with xatlas.
"""

from __future__ import annotations

import importlib
from typing import Any

from dressmeup.errors import InputError
from dressmeup.methods.uvparam.base import UVResult

__all__ = ["UVResult", "get_method", "METHODS"]

METHODS = {
    "xatlas": ("dressmeup.methods.uvparam.xatlas_method", "XatlasMethod"),
    "lscm": ("dressmeup.methods.uvparam.lscm", "LSCMMethod"),
    "harmonic": ("dressmeup.methods.uvparam.harmonic", "HarmonicMethod"),
    "slim": ("dressmeup.methods.uvparam.slim", "SLIMMethod"),
    "neural": ("dressmeup.methods.uvparam.neural.method", "NeuralMethod"),
    "lscm-on-charts": ("dressmeup.methods.uvparam.lscm_charts", "LSCMOnChartsMethod"),
}


def get_method(name: str, **hyperparameters: Any):
    """Build a UV-parameterisation method by name.

    Parameters
    ----------
    name : {"xatlas", "lscm", "harmonic", "slim", "neural"}
    **hyperparameters
        Keyword arguments of the method's class.

    Returns
    -------
    object with ``parameterize(V (n, 3), F (m, 3)) -> UVResult``.

    Raises
    ------
    ValueError
        Unknown method name.
    """
    if name not in METHODS:
        raise InputError(f"method: expected one of {', '.join(METHODS)}, got {name!r}")
    module, cls = METHODS[name]
    return getattr(importlib.import_module(module), cls)(**hyperparameters)
