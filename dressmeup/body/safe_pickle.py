"""Load model pickles without letting them run code.

SMPL-family ``.pkl`` files are Python pickles (often Python 2, protocol 2) of a dict of
numpy arrays, scipy sparse matrices and sometimes ``chumpy`` objects. A pickle can name any
importable callable, so plain ``pickle.load`` on an untrusted file can run arbitrary code.
:func:`safe_load_pickle` resolves only an allow-list of numpy/scipy reconstruction helpers;
``chumpy`` classes are replaced by a stand-in (chumpy is never imported) whose value is
read back as a plain array. Anything else (``os.system``, ``eval``, code objects, ...) is
refused with :class:`~dressmeup.errors.InputError`. Before any of it runs, the file's size
and what its opcodes would build are bounded (:func:`dressmeup.io.pickles.read_pickle_bytes`:
a 200-byte "billion laughs" pickle is refused, not expanded), and a sparse matrix whose
dense form would pass the ``array_bytes`` limit is refused before anyone densifies it.
"""

from __future__ import annotations

import io
import os
import pickle
from pathlib import Path

import numpy as np

from dressmeup.errors import InputError
from dressmeup.io.pickles import read_pickle_bytes
from dressmeup.limits import ARRAY_BYTES

_ALLOWED = {
    ("numpy.core.multiarray", "_reconstruct"),
    ("numpy._core.multiarray", "_reconstruct"),
    ("numpy.core.multiarray", "scalar"),
    ("numpy._core.multiarray", "scalar"),
    ("numpy", "ndarray"),
    ("numpy", "dtype"),
    ("numpy.core.numeric", "_frombuffer"),
    ("numpy._core.numeric", "_frombuffer"),
    ("copyreg", "_reconstructor"),
    ("copy_reg", "_reconstructor"),
    ("_codecs", "encode"),  # bytes in protocol-2 pickles written by Python 3
    ("builtins", "object"),
    ("__builtin__", "object"),
    ("builtins", "set"),
    ("builtins", "frozenset"),
    ("builtins", "slice"),
    ("builtins", "complex"),
}
_SPARSE = {"csc_matrix", "csr_matrix", "coo_matrix", "csc_array", "csr_array", "coo_array"}


class ChumpyStandIn:
    """Replaces any ``chumpy`` object while unpickling; keeps its pickled state only."""

    def __setstate__(self, state):
        self.state = state

    def to_array(self) -> np.ndarray | None:
        """The object's value as an array (chumpy keeps it in ``x``), or None."""
        state = getattr(self, "state", None)
        if isinstance(state, dict):
            for key in ("x", "a", "r"):
                value = state.get(key)
                if isinstance(value, ChumpyStandIn):
                    value = value.to_array()
                if isinstance(value, np.ndarray):
                    return value
        return None


class _RestrictedUnpickler(pickle.Unpickler):
    def __init__(self, fh, source: str):
        super().__init__(fh, encoding="latin1", fix_imports=True)
        self._source = source

    def find_class(self, module: str, name: str):
        if (module, name) in _ALLOWED:
            return super().find_class(module, name)
        if module.startswith("scipy.sparse") and name in _SPARSE:
            # heavy: scipy.sparse
            import scipy.sparse

            return getattr(scipy.sparse, name)
        if module == "chumpy" or module.startswith("chumpy."):
            return ChumpyStandIn
        raise InputError(
            f"{self._source}: refused to load: the pickle asks for '{module}.{name}', but model "
            "files may only contain plain numpy/scipy arrays (a pickle that names other "
            "callables could run code on this machine)"
        )


def _clean(value, source: str = "pickle"):
    """Turn stand-ins into plain arrays, recursively for dicts/lists; sparse matrices whose
    dense form passes the ``array_bytes`` limit are refused."""
    if hasattr(value, "toarray") and hasattr(value, "shape"):
        shape = tuple(int(n) for n in value.shape)
        dense = 8 * (shape[0] if shape else 1) * (shape[1] if len(shape) > 1 else 1)
        ARRAY_BYTES.check(dense, source, f"sparse matrix of shape {shape}, dense")
        return value
    if isinstance(value, ChumpyStandIn):
        arr = value.to_array()
        return value if arr is None else arr
    if isinstance(value, dict):
        return {k: _clean(v, source) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return type(value)(_clean(v, source) for v in value)
    return value


def safe_load_pickle(path: str | os.PathLike):
    """Unpickle ``path`` allowing only numpy/scipy array reconstruction.

    Returns
    -------
    The unpickled object with chumpy objects replaced by numpy arrays.

    Raises
    ------
    InputError : the pickle references anything outside the allow-list (message names the
        file and the refused callable), is not a readable pickle, is nested too deeply, or
        would build more than the limits of :mod:`dressmeup.limits` allow.
    """
    path = Path(path)
    data = read_pickle_bytes(path)
    try:
        obj = _RestrictedUnpickler(io.BytesIO(data), str(path)).load()
        return _clean(obj, str(path))
    except InputError:
        raise
    except RecursionError as exc:
        raise InputError(f"{path}: the pickle is nested too deeply to read") from exc
    except Exception as exc:  # corrupt or truncated files
        raise InputError(f"{path}: not a readable model pickle ({type(exc).__name__}: {exc})") from exc
