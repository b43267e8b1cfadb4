"""``KEY=VALUE`` hyperparameters from the command line: the one parsing rule.

Every ``--param`` option of the toolkit (``dressmeup baseline retarget|uvparam``,
``train-retarget``, ``train-uvparam``) and the benchmark scripts use :func:`parse_params`, so a
value means the same everywhere:

============================  =======================================================
text (case-insensitive words)  value
============================  =======================================================
``none``, ``null``             ``None``
``true``, ``false``            ``True``, ``False``
an integer (``3``, ``-2``)     ``int``
a decimal (``0.5``, ``1e-3``)  ``float`` (``inf`` and ``nan`` too)
``[...]`` or ``{...}``         the JSON list / object (invalid JSON is an error)
``"..."``                      the JSON string inside the quotes (to pass ``"3"``)
anything else                  the text itself, as a ``str``
============================  =======================================================
"""

from __future__ import annotations

import dataclasses
import json
import numbers
from collections.abc import Iterable, Mapping
from typing import Any, TypeVar

from dressmeup.errors import InputError

__all__ = ["parse_value", "parse_params", "resolve_config"]

T = TypeVar("T")


def parse_value(text: str) -> Any:
    """One value by the rule of the module docstring.

    Parameters
    ----------
    text : str

    Returns
    -------
    None, bool, int, float, list, dict or str.

    Raises
    ------
    InputError
        For text that starts like JSON (``[``, ``{``, ``"``) but is not valid JSON.
    """
    s = text.strip()
    low = s.lower()
    if low in ("none", "null"):
        return None
    if low in ("true", "false"):
        return low == "true"
    if s[:1] in ("[", "{", '"'):
        try:
            return json.loads(s)
        except json.JSONDecodeError as exc:
            raise InputError(f"value {text!r}: looks like JSON but is not valid JSON ({exc.msg}); "
                             f"quote lists and objects for the shell, e.g. '[64, 64]'") from None
    try:
        return int(s)
    except ValueError:
        pass
    try:
        return float(s)
    except ValueError:
        return s


def parse_params(items: Iterable[str], flag: str = "--param") -> dict[str, Any]:
    """``["k=v", ...]`` -> ``{"k": parse_value("v"), ...}`` (a later key wins).

    Parameters
    ----------
    items : strings ``KEY=VALUE`` (the value may contain ``=``).
    flag : the option name used in error messages.

    Raises
    ------
    InputError
        For an item without ``=`` or with an empty key.
    """
    out: dict[str, Any] = {}
    for item in items:
        key, sep, value = item.partition("=")
        key = key.strip()
        if not sep or not key:
            raise InputError(f"{flag} {item!r}: expected KEY=VALUE, e.g. {flag} width=256")
        out[key] = parse_value(value)
    return out


def resolve_config(presets: Mapping[str, T], config: str | T, overrides: Mapping[str, Any],
                   what: str = "config") -> T:
    """A frozen dataclass configuration from a preset (its name, or a config object) and
    validated keyword overrides: the one rule behind every ``get_config`` of the toolkit.

    Parameters
    ----------
    presets : preset name -> configuration (all of one frozen dataclass type).
    config : a preset name or a configuration of that type.
    overrides : field name -> value. ``int`` fields take integers (not booleans), ``float``
        fields any real number (stored as float), ``bool`` fields booleans, ``str`` fields
        strings; fields of other types take the value as given.
    what : how error messages name the configuration.

    Raises
    ------
    InputError
        Unknown preset, unknown field (the message lists the valid ones) or a value of the
        wrong type.
    """
    kind = type(next(iter(presets.values())))
    if isinstance(config, kind):
        base = config
    elif isinstance(config, str) and config in presets:
        base = presets[config]
    else:
        raise InputError(f"{what}: expected one of the presets {sorted(presets)} or a "
                         f"{kind.__name__}, got {config!r}")
    types = {f.name: str(f.type) for f in dataclasses.fields(kind)}
    bad = sorted(set(overrides) - set(types))
    if bad:
        raise InputError(f"{what}: unknown setting(s) {bad}; valid: {sorted(types)}")
    clean = {}
    for name, value in overrides.items():
        t = types[name]
        if t == "bool" and not isinstance(value, bool):
            raise InputError(f"{what}.{name}: expected true or false, got {value!r}")
        if t == "int" and (isinstance(value, bool) or not isinstance(value, numbers.Integral)):
            raise InputError(f"{what}.{name}: expected an integer, got {value!r}")
        if t == "float":
            if isinstance(value, bool) or not isinstance(value, numbers.Real):
                raise InputError(f"{what}.{name}: expected a number, got {value!r}")
            value = float(value)
        if t == "str" and not isinstance(value, str):
            raise InputError(f"{what}.{name}: expected a string, got {value!r}")
        clean[name] = int(value) if t == "int" else value
    return dataclasses.replace(base, **clean)
