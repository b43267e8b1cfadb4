"""What every baseline run shares: the log callback, the authors line of reference
submissions, the registries of installed baselines and their shipped weights."""

from __future__ import annotations

import importlib
from collections.abc import Callable
from pathlib import Path
from typing import Any

from dressmeup.errors import InputError

Log = Callable[[str], Any]


def _quiet(_line: str) -> None:
    return None


#: ``submission.json`` ``authors`` of the toolkit's reference baselines.
BASELINE_AUTHORS = "dressmeup reference baselines"


class SkippedBaseline(InputError):
    """A baseline that cannot run in this configuration (the message says why and what to do)."""


def shipped_weights(method: Any, body_model: str) -> Path | None:
    """The checkpoint a trainable method ships for ``body_model`` (None when there is none):
    ``<stem>_<body_model>.pt`` in the ``WEIGHTS_DIR`` of the module of the method's class or
    of a class it derives from; a post-process chain's base method's."""
    base = getattr(method, "method", method)  # a chain's base method
    wdir = next((d for cls in type(base).__mro__
                 if (d := getattr(importlib.import_module(cls.__module__), "WEIGHTS_DIR", None))
                 is not None), None)
    if wdir is None:
        return None
    stem = getattr(base, "weights_stem", None)
    hits = sorted(Path(wdir).glob(f"{stem}_{body_model}.pt" if stem else f"*_{body_model}.pt"))
    return hits[0] if hits else None


def retarget_methods() -> list[str]:
    """Names of the retargeting baselines this installation provides ([] when none)."""
    try:
        mod = importlib.import_module("dressmeup.methods.retarget")
    except ImportError:
        return []
    names = getattr(mod, "available_methods", None)
    return list(names()) if callable(names) else list(getattr(mod, "METHODS", {}))


def uvparam_methods() -> list[str]:
    """Names of the UV baselines this installation provides ([] when none)."""
    try:
        mod = importlib.import_module("dressmeup.methods.uvparam")
    except ImportError:
        return []
    return list(getattr(mod, "METHODS", {}))


def registration_methods() -> list[str]:
    """Names of the registration baselines: ``register``, the toolkit's registrar with its
    default options (:func:`dressmeup.body.registration.register`)."""
    return ["register"]
