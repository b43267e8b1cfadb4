"""Progress for long work: a tqdm bar on a terminal (or in a notebook), a plain line now and
then in a log; silent when ``DRESSMEUP_NO_PROGRESS`` is set. Work that is one long call
(building a body model) shows a line every little while instead (:func:`working`).

A bar redraws itself with carriage returns up to ten times a second. Written to a file or a
pipe (``dressmeup demo > log 2>&1``, CI) every redraw stays in the log, so there the same
work prints one complete line at most every :data:`LINE_INTERVAL_S` seconds and a closing
line, and work that ends sooner prints nothing.
"""

from __future__ import annotations

import contextlib
import os
import sys
import threading
from collections.abc import Callable, Iterable, Iterator
from time import monotonic
from typing import TypeVar

from tqdm.auto import tqdm

T = TypeVar("T")

LINE_INTERVAL_S = 30.0
"""Least time (s) between two progress lines when stderr is not a terminal."""


def progress(iterable: Iterable[T], desc: str = "", total: int | None = None,
             disable: bool | None = None, initial: int = 0) -> Iterator[T]:
    """Wrap ``iterable`` in progress reporting on stderr.

    Parameters
    ----------
    iterable : iterable to wrap.
    desc : short label shown before the bar or at the start of each line.
    total : number of items when ``iterable`` has no ``len``.
    disable : force reporting off (default: off when ``DRESSMEUP_NO_PROGRESS`` is set).
    initial : items done before this run (resumed work; ``iterable`` holds the rest): counted
        in ``k/total``, not in the rate the time left is estimated from.

    Returns
    -------
    An iterator over the same items: a tqdm bar when stderr is a terminal or in a notebook,
    otherwise the timed lines of :func:`_log_lines`.
    """
    if disable is None:
        disable = bool(os.environ.get("DRESSMEUP_NO_PROGRESS"))
    if disable:
        return iter(iterable)
    if _bar_wanted():
        return iter(tqdm(iterable, desc=desc, total=total, initial=initial, leave=False,
                         dynamic_ncols=True))
    if total is None:
        total = len(iterable) + initial if hasattr(iterable, "__len__") else None
    return _log_lines(iterable, desc, total, initial)


@contextlib.contextmanager
def working(desc: str, every: float | None = None,
            write: Callable[[str], object] | None = None) -> Iterator[None]:
    """Print ``desc: m:ss elapsed`` every ``every`` seconds while the block runs (one long
    call that cannot report its own progress), and ``desc: done in m:ss`` after it when any
    line was printed; nothing for work that ends sooner.

    Parameters
    ----------
    desc : what is being done (``"building the anny body model"``).
    every : seconds between lines (default: 10 s on a terminal, :data:`LINE_INTERVAL_S`
        in a log).
    write : where lines go (default: stderr); silent when ``DRESSMEUP_NO_PROGRESS`` is set.
    """
    if os.environ.get("DRESSMEUP_NO_PROGRESS"):
        yield
        return
    every = every if every is not None else (10.0 if _bar_wanted() else LINE_INTERVAL_S)
    out = write or _write
    stop = threading.Event()
    t0 = monotonic()
    printed = []

    def beat() -> None:
        while not stop.wait(every):
            out(f"{desc}: {tqdm.format_interval(monotonic() - t0)} elapsed")
            printed.append(True)

    thread = threading.Thread(target=beat, name="dressmeup-working", daemon=True)
    thread.start()
    try:
        yield
    finally:
        stop.set()
        thread.join()
        if printed:
            out(f"{desc}: done in {tqdm.format_interval(monotonic() - t0)}")


def _bar_wanted() -> bool:
    """True when a redrawn bar reads well: stderr is a terminal, or tqdm found a notebook."""
    if any(c.__module__ == "tqdm.notebook" for c in tqdm.__mro__):
        return True
    isatty = getattr(sys.stderr, "isatty", None)
    return bool(isatty and isatty())


def _log_lines(iterable: Iterable[T], desc: str, total: int | None,
               initial: int = 0) -> Iterator[T]:
    """Yield the items of ``iterable``; after an item, print ``desc: k/total (p %), mm:ss
    elapsed, ~mm:ss left`` when :data:`LINE_INTERVAL_S` has passed since the start or the
    last line (``k`` counts from ``initial``); at the end print ``desc: done, n items in
    mm:ss`` (``n`` of this run) if any line was printed."""
    t0 = last = monotonic()
    printed = False
    k = initial
    for item in iterable:
        yield item
        k += 1
        now = monotonic()
        if now - last >= LINE_INTERVAL_S:
            _write(_line(desc, k, total, now - t0, initial))
            printed, last = True, now
    if printed:
        _write(f"{desc}: done, {k - initial} items in "
               f"{tqdm.format_interval(monotonic() - t0)}")


def _line(desc: str, k: int, total: int | None, elapsed: float, initial: int = 0) -> str:
    """One progress line: items done (of ``total`` with a share and an estimate of the time
    left, from this run's rate, when it is known) and the elapsed time (s, printed mm:ss)."""
    spent = tqdm.format_interval(elapsed)
    if not total:
        return f"{desc}: {k} done, {spent} elapsed"
    rest = (f", ~{tqdm.format_interval(elapsed * max(total - k, 0) / (k - initial))} left"
            if k > initial else "")
    return f"{desc}: {k}/{total} ({100 * k / total:.0f} %), {spent} elapsed{rest}"


def _write(line: str) -> None:
    """Print ``line`` on stderr at once (a log being followed shows it)."""
    stream = sys.stderr
    stream.write(line + "\n")
    stream.flush()
