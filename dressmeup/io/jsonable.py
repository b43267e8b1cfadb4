"""JSON of numpy-bearing records: the one ``default=`` hook for :func:`json.dumps`.

Example
-------
>>> json.dumps({"n": np.int64(3), "x": np.zeros(2)}, default=json_default)
'{"n": 3, "x": [0.0, 0.0]}'
"""

from __future__ import annotations

import dataclasses
from pathlib import PurePath
from typing import Any

import numpy as np

__all__ = ["json_default"]


def json_default(o: Any) -> Any:
    """Turn what :mod:`json` cannot write into what it can.

    numpy scalars -> Python numbers, arrays -> nested lists, paths -> strings, dataclass
    instances -> dicts. Anything else raises ``TypeError`` (as :func:`json.dumps` would)
    instead of being written as an opaque ``str(o)``.
    """

    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, PurePath):
        return str(o)
    if dataclasses.is_dataclass(o) and not isinstance(o, type):
        return dataclasses.asdict(o)
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")
