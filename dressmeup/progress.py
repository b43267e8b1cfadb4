"""Progress bars for long work (tqdm), silent when ``DRESSMEUP_NO_PROGRESS`` is set."""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator
from typing import TypeVar

from tqdm.auto import tqdm

T = TypeVar("T")


def progress(iterable: Iterable[T], desc: str = "", total: int | None = None,
             disable: bool | None = None) -> Iterator[T]:
    """Wrap ``iterable`` in a progress bar on stderr.

    Parameters
    ----------
    iterable : iterable to wrap.
    desc : short label shown before the bar.
    total : number of items when ``iterable`` has no ``len``.
    disable : force the bar off (default: off when ``DRESSMEUP_NO_PROGRESS`` is set).
    """
    if disable is None:
        disable = bool(os.environ.get("DRESSMEUP_NO_PROGRESS"))
    return iter(tqdm(iterable, desc=desc, total=total, disable=disable, leave=False,
                     dynamic_ncols=True))
