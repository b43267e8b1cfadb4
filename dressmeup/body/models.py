"""Registry of body models by name: ``get_body_model(name, **kw)``."""

from __future__ import annotations

import importlib
import threading
from collections.abc import Callable

from dressmeup.errors import InputError

_FACTORIES: dict[str, Callable[..., object]] = {}
_BUILTIN = {
    "anny": ("dressmeup.body.anny_model", "AnnyBody"),
    "procedural": ("dressmeup.body.procedural", "ProceduralBody"),
    "smpl": ("dressmeup.body.smpl", "SMPLBody"),
    "smplh": ("dressmeup.body.smpl", "SMPLHBody"),
    "smplx": ("dressmeup.body.smpl", "SMPLXBody"),
}
_INSTANCES: dict[tuple, object] = {}
_LOCK = threading.Lock()


def register_body_model(name: str, factory: Callable[..., object]) -> None:
    """Register ``factory(**kw) -> BodyModel`` under ``name`` (overrides a built-in)."""
    if not isinstance(name, str) or not name:
        raise InputError(f"name: expected a non-empty string, got {name!r}")
    _FACTORIES[name] = factory


def available_body_models() -> list[str]:
    """Names accepted by :func:`get_body_model`."""
    return sorted(set(_BUILTIN) | set(_FACTORIES))


def get_body_model(name: str = "anny", **kw):
    """Return the body model ``name`` (``anny`` default, ``procedural``, ``smpl``, ...).

    Instances are cached per (name, keyword arguments), so the expensive build of the default
    model happens once per process (and its on-disk cache once per machine).

    Raises
    ------
    ValueError : unknown name (the message lists the known ones).
    MissingModelError : an SMPL-family model file is missing (says where to put it).
    """
    try:
        key = (name, tuple(sorted((k, repr(v)) for k, v in kw.items())))
    except TypeError:
        key = None
    if key is not None and key in _INSTANCES:
        return _INSTANCES[key]
    if name in _FACTORIES:
        factory = _FACTORIES[name]
    elif name in _BUILTIN:
        mod, cls = _BUILTIN[name]
        factory = getattr(importlib.import_module(mod), cls)
    else:
        raise InputError(f"unknown body model {name!r}; known: {available_body_models()}")
    with _LOCK:
        model = factory(**kw)
        if key is not None:
            _INSTANCES[key] = model
    return model
