"""Reading network checkpoints that a user hands over (``--weights``, ``--checkpoint``).

``torch.load(weights_only=True)`` refuses arbitrary callables, but not size: its pickle can
still be a "billion laughs", its archive can hold a hundred thousand members or declare
gigabytes, and anything that is not a checkpoint fails with torch's own traceback.
:func:`load_checkpoint` checks the file first (a zip-format checkpoint as ``torch.save``
writes it, members within ``archive_members``, declared sizes within ``array_bytes``, the
pickle's opcodes within ``pickle_objects``: :mod:`dressmeup.limits`), then loads it with
``weights_only=True`` and checks its ``format`` field; every failure is an
:class:`~dressmeup.errors.InputError` naming the file.
"""

from __future__ import annotations

import os
import zipfile
from pathlib import Path
from typing import Any

from dressmeup.errors import InputError
from dressmeup.io.pickles import scan_pickle
from dressmeup.limits import ARCHIVE_MEMBERS, ARRAY_BYTES, PICKLE_BYTES, bounded_file


def _check_archive(path: Path, what: str) -> None:
    try:
        with zipfile.ZipFile(path) as zf:
            members = zf.infolist()
            ARCHIVE_MEMBERS.check(len(members), f"{what} {path}", "members")
            ARRAY_BYTES.check(sum(m.file_size for m in members), f"{what} {path}",
                              "declared size (uncompressed)")
            pickles = [m for m in members if m.filename.endswith("data.pkl")]
            if len(pickles) != 1:
                raise InputError(f"{what} {path}: not a torch checkpoint (no data.pkl)")
            PICKLE_BYTES.check(pickles[0].file_size, f"{what} {path}", "data.pkl size")
            scan_pickle(zf.read(pickles[0]), f"{what} {path} (data.pkl)")
    except zipfile.BadZipFile as exc:
        raise InputError(f"{what} {path}: not a checkpoint written by torch.save (not a zip "
                         f"archive: {exc})") from exc


def load_checkpoint(path: str | os.PathLike, what: str = "checkpoint",
                    fmt: str | None = None, keys: tuple[str, ...] = ()) -> dict[str, Any]:
    """A checkpoint's dictionary, loaded on the CPU after the checks above.

    Parameters
    ----------
    path : the ``.pt`` file.
    what : how messages name it (``"isomap-refine weights"``).
    fmt : the value its ``format`` field must have (None: any dict).
    keys : fields it must hold.

    Raises
    ------
    FileNotFoundError, InputError
    """
    # heavy: torch (~1.1 s to import)
    import torch

    path = bounded_file(path, what)
    _check_archive(path, what)
    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:  # noqa: BLE001 - torch raises many types on foreign files
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
        raise InputError(f"{what} {path}: not a readable checkpoint ({type(exc).__name__}: "
                         f"{first[:200]})") from exc
    if not isinstance(state, dict) or (fmt is not None and state.get("format") != fmt):
        got = state.get("format") if isinstance(state, dict) else type(state).__name__
        raise InputError(f"{what} {path}: not a {fmt or 'checkpoint'} file (found {got!r})")
    missing = [k for k in keys if k not in state]
    if missing:
        raise InputError(f"{what} {path}: damaged checkpoint (no {', '.join(missing)})")
    return state
