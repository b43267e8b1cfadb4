"""The toolkit's one cache directory.

Everything expensive that can be rebuilt (body-model builds, geodesic matrices, embeddings,
differential operators) lives under one folder that the user can move with the environment
variable ``DRESSMEUP_CACHE`` (default ``~/.cache/dressmeup``), in sub-folders keyed by a hash
of their inputs.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numpy as np

ENV_VAR = "DRESSMEUP_CACHE"


def cache_root() -> Path:
    """Return the cache root (created if missing): ``$DRESSMEUP_CACHE`` or ``~/.cache/dressmeup``."""
    root = os.environ.get(ENV_VAR)
    path = Path(root) if root else Path.home() / ".cache" / "dressmeup"
    path.mkdir(parents=True, exist_ok=True)
    return path


def cache_dir(name: str) -> Path:
    """Return (and create) the sub-folder ``name`` of the cache root."""
    path = cache_root() / name
    path.mkdir(parents=True, exist_ok=True)
    return path


def hash_arrays(*arrays: np.ndarray, extra: str = "") -> str:
    """Return a short stable hex key for a set of arrays (dtype, shape and bytes) and a string."""
    h = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(str(a.dtype).encode())
        h.update(str(a.shape).encode())
        h.update(a.tobytes())
    h.update(extra.encode())
    return h.hexdigest()[:20]
