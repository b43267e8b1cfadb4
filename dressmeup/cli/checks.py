"""Argument types of the command line: numbers in range, finite, within the resource limits.

Each factory returns an ``argparse`` type: a bad value is a usage error naming the option
(``argument --samples: expected an integer from 1 to 20,000,000 (surface_samples), got
'2000000000'``, exit status 2) before any work starts. A bound taken from
:mod:`dressmeup.limits` is read when the option is parsed, after ``dressmeup --max``.
"""

from __future__ import annotations

import argparse
import math
import os
import re
from collections.abc import Callable
from pathlib import Path

from dressmeup.errors import InputError
from dressmeup.limits import Limit, by_name

#: Largest seed: numpy's generators take any non-negative integer; a 64-bit one is plenty.
MAX_SEED = 2**64 - 1


def _bound_text(hi: int | float | Limit | None) -> tuple[float, str]:
    if hi is None:
        return math.inf, ""
    if isinstance(hi, Limit):
        value = hi.value()
        return value, f" to {value:,} ({hi.name}; {hi.how_to_raise()})"
    return hi, f" to {hi:,}" if isinstance(hi, int) else f" to {hi:g}"


def integer(lo: int = 0, hi: int | Limit | None = None) -> Callable[[str], int]:
    """An integer in ``[lo, hi]`` (``hi`` a number or a limit of :mod:`dressmeup.limits`)."""

    def parse(text: str) -> int:
        top, top_text = _bound_text(hi)
        want = f"an integer from {lo:,}{top_text}" if top_text else f"an integer >= {lo:,}"
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {want}, got {text!r}") from None
        if not lo <= value <= top:
            raise argparse.ArgumentTypeError(f"expected {want}, got {text!r}")
        return value

    parse.__name__ = "integer"
    return parse


def number(lo: float = 0.0, hi: float | None = None, lo_open: bool = False,
           unit: str = "") -> Callable[[str], float]:
    """A finite number in ``[lo, hi]`` (``(lo, hi]`` with ``lo_open``), in ``unit``."""

    def parse(text: str) -> float:
        left = "(" if lo_open else "["
        rng = f"{left}{lo:g}, {hi:g}]" if hi is not None else (
            f"> {lo:g}" if lo_open else f">= {lo:g}")
        want = f"a finite number {'in ' if hi is not None else ''}{rng}" + (
            f" {unit}" if unit else "")
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {want}, got {text!r}") from None
        if not math.isfinite(value) or value < lo or (lo_open and value == lo) or \
                (hi is not None and value > hi):
            raise argparse.ArgumentTypeError(f"expected {want}, got {text!r}")
        return value

    parse.__name__ = "number"
    return parse


def seed(text: str) -> int:
    """A random seed: an integer from 0 to 2^64 - 1."""
    return integer(0, MAX_SEED)(text)


def new_output(text: str) -> str:
    """An output folder: anything but an existing file (or link to one)."""
    p = Path(text)
    if text.strip() == "":
        raise argparse.ArgumentTypeError("expected a folder path, got ''")
    if p.exists() and not p.is_dir():
        raise argparse.ArgumentTypeError(f"{text} is an existing file; give a folder")
    return text


def output_file(text: str) -> str:
    """An output file: anything but an existing folder."""
    if text.strip() == "":
        raise argparse.ArgumentTypeError("expected a file path, got ''")
    if Path(text).is_dir():
        raise argparse.ArgumentTypeError(f"{text} is a folder; give the file to write")
    return text


def device(text: str) -> str:
    """``cpu`` or ``cuda``/``cuda:N``."""
    if not re.fullmatch(r"cpu|cuda(:\d{1,2})?", text):
        raise argparse.ArgumentTypeError(f"expected cpu, cuda or cuda:N, got {text!r}")
    return text


def http_url(text: str) -> str:
    """An ``http://`` or ``https://`` URL with a host."""
    if not re.fullmatch(r"https?://[^\s/]+(/\S*)?", text):
        raise argparse.ArgumentTypeError(f"expected an http(s) URL such as "
                                         f"http://127.0.0.1:8000, got {text!r}")
    return text


def host(text: str) -> str:
    """A host name or address to listen on (no spaces, no scheme)."""
    if not re.fullmatch(r"[A-Za-z0-9.\-:\[\]]{1,253}", text):
        raise argparse.ArgumentTypeError(f"expected a host name or IP address such as "
                                         f"127.0.0.1, got {text!r}")
    return text


def team_name(text: str) -> str:
    """A team name: 1 to 64 printable characters, not only spaces."""
    if not text.strip() or len(text) > 64 or not text.isprintable():
        raise argparse.ArgumentTypeError(f"expected 1 to 64 printable characters, got "
                                         f"{text!r}")
    return text


class SetLimit(argparse.Action):
    """``--max NAME=VALUE``: set a limit of :mod:`dressmeup.limits` for this run (the
    previous environment is in ``namespace.max``, for :func:`dressmeup.cli.main` to put
    back)."""

    def __call__(self, parser, namespace, values, option_string=None):
        name, sep, value = str(values).partition("=")
        try:
            lim = by_name(name.strip().lower())
        except InputError as exc:
            parser.error(f"argument --max: {exc}")
        if not sep:
            parser.error(f"argument --max: expected NAME=VALUE, got {values!r}")
        saved = getattr(namespace, self.dest, None) or {}
        saved.setdefault(lim.env, os.environ.get(lim.env))
        setattr(namespace, self.dest, saved)
        os.environ[lim.env] = value.strip()
        try:
            lim.value()
        except InputError as exc:
            parser.error(f"argument --max {name}: {exc}")
