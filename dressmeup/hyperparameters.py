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

import json
from collections.abc import Iterable
from typing import Any

from dressmeup.errors import InputError

__all__ = ["parse_value", "parse_params"]


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
